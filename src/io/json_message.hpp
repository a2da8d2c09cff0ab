// The JSON library's error messages as cdshear shows them.
#pragma once

#include <exception>
#include <string>

namespace cdshear {

/// The message of a JSON library exception without the library's tag: "[json.exception.
/// parse_error.101] parse error at line 1, column 3: ..." becomes "parse error at line 1,
/// column 3: ...". Any other exception's message is returned whole.
inline std::string json_message(const std::exception& e) {
  const std::string what = e.what();
  if (!what.starts_with("[json.exception.")) return what;
  const std::size_t tag_end = what.find("] ");
  return tag_end == std::string::npos ? what : what.substr(tag_end + 2);
}

}  // namespace cdshear
