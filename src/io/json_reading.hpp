// Reading JSON as cdshear's readers do: the library's messages without its tag, and whole numbers
// however JSON writes them.
#pragma once

#include <cstdint>
#include <exception>
#include <nlohmann/json.hpp>
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

/// True for a whole number >= 0, "-0" included (the library reads it as a signed 0); then
/// v.get<std::uint64_t>() is its value. A fraction, a negative number or another type is not.
inline bool is_whole_number(const nlohmann::json& v) {
  return v.is_number_unsigned() || (v.is_number_integer() && v.get<std::int64_t>() >= 0);
}

}  // namespace cdshear
