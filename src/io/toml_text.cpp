// TOML text with floats in their shortest exact form (toml_text.hpp).
#include "toml_text.hpp"

#include <fmt/format.h>

#include <sstream>

namespace cdshear {
namespace {

/// One node through toml++'s formatter (strings, dates, times): its escapes are TOML's.
std::string library_text(const toml::node& node) {
  std::ostringstream out;
  out << toml::toml_formatter{node, toml::format_flags::allow_unicode_strings};
  return out.str();
}

/// A key as written before ` = ` or inside a header: bare when TOML allows ([A-Za-z0-9_-]+),
/// quoted otherwise.
std::string key_text(std::string_view key) {
  bool bare = !key.empty();
  for (const char ch : key)
    bare = bare && ((ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') ||
                    (ch >= '0' && ch <= '9') || ch == '_' || ch == '-');
  return bare ? std::string(key) : library_text(toml::value<std::string>(std::string(key)));
}

/// A sub-table written under a header of its own, not inline in its parent's lines.
bool is_section(const toml::node& node) {
  const toml::table* t = node.as_table();
  return t != nullptr && !t->is_inline();
}

bool is_array_of_sections(const toml::node& node) {
  const toml::array* a = node.as_array();
  if (a == nullptr || a->empty()) return false;
  for (const toml::node& item : *a)
    if (!is_section(item)) return false;
  return true;
}

void write_table(const toml::table& table, const std::string& path, std::string& out) {
  for (const auto& [key, value] : table)
    if (!is_section(value) && !is_array_of_sections(value))
      out += key_text(key.str()) + " = " + toml_value_text(value) + "\n";
  for (const auto& [key, value] : table) {
    const std::string sub = (path.empty() ? "" : path + ".") + key_text(key.str());
    if (is_section(value)) {
      // A header for a table with keys of its own, or with nothing at all (`[set]` empty: the
      // table still exists when read back); a table of tables alone needs none.
      const toml::table& t = *value.as_table();
      bool own_keys = t.empty();
      for (const auto& [k, v] : t) own_keys = own_keys || !is_section(v);
      if (own_keys) out += (out.empty() ? "[" : "\n[") + sub + "]\n";
      write_table(t, sub, out);
    } else if (is_array_of_sections(value)) {
      for (const toml::node& item : *value.as_array()) {
        out += (out.empty() ? "[[" : "\n[[") + sub + "]]\n";
        write_table(*item.as_table(), sub, out);
      }
    }
  }
}

}  // namespace

std::string toml_float_text(double v) {
  std::string s = fmt::format("{}", v);
  if (const std::size_t e = s.find('e'); e != std::string::npos) {
    // 1e-05 -> 1e-5: the exponent without leading zeros.
    std::size_t digits = e + 1;
    if (digits < s.size() && (s[digits] == '-' || s[digits] == '+')) ++digits;
    while (digits + 1 < s.size() && s[digits] == '0') s.erase(digits, 1);
    if (s[e + 1] == '+') s.erase(e + 1, 1);
    return s;
  }
  if (s.find_first_of(".ni") == std::string::npos) s += ".0";  // n, i: nan, inf
  return s;
}

std::string toml_value_text(const toml::node& node) {
  if (const auto* x = node.as_floating_point()) return toml_float_text(x->get());
  if (const auto* x = node.as_integer()) return std::to_string(x->get());
  if (const auto* x = node.as_boolean()) return x->get() ? "true" : "false";
  if (const toml::array* array = node.as_array()) {
    std::string text = "[";
    for (std::size_t i = 0; i < array->size(); ++i)
      text += (i ? ", " : "") + toml_value_text((*array)[i]);
    return text + "]";
  }
  if (const toml::table* table = node.as_table()) {
    std::string text = "{";
    bool first = true;
    for (const auto& [key, value] : *table) {
      text += (first ? " " : ", ") + key_text(key.str()) + " = " + toml_value_text(value);
      first = false;
    }
    return text + (table->empty() ? "}" : " }");
  }
  return library_text(node);
}

std::string toml_document_text(const toml::table& table) {
  std::string out;
  write_table(table, "", out);
  return out;
}

}  // namespace cdshear
