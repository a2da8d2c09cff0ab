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

namespace detail {
/// Appends v's JSON to text, arrays and objects nested deeper than `depth_left` levels as [...] and
/// {...}, and stops adding elements once text holds more than `limit` characters.
inline void append_json_shown(const nlohmann::json& v, int depth_left, std::size_t limit,
                              std::string& text) {
  if (!v.is_structured()) {
    text += v.dump();
    return;
  }
  const bool array = v.is_array();
  if (depth_left == 0 && !v.empty()) {
    text += array ? "[...]" : "{...}";
    return;
  }
  text += array ? '[' : '{';
  bool first = true;
  for (auto it = v.begin(); it != v.end() && text.size() <= limit; ++it) {
    if (!first) text += ',';
    first = false;
    if (!array) text += nlohmann::json(it.key()).dump() + ':';
    append_json_shown(*it, depth_left - 1, limit, text);
  }
  text += array ? ']' : '}';
}
}  // namespace detail

/// A value as an error message shows it: its JSON, cut to `limit` characters, arrays and objects
/// nested more than four levels deep shown as [...] and {...}. (The library's dump() recurses once
/// per level: a packing whose `n` was 100 000 nested brackets overflowed the stack while its error
/// was written.) A value the message compares with another (a path) takes a larger limit.
inline std::string json_shown(const nlohmann::json& v, std::size_t limit = 60) {
  std::string text;
  detail::append_json_shown(v, 4, limit, text);
  return text.size() > limit ? text.substr(0, limit - 3) + "..." : text;
}

/// The limit of json_shown for a value compared with another in the message: a case's whole path.
inline constexpr std::size_t kComparedValueLimit = 4096;

}  // namespace cdshear
