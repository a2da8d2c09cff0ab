#include "toml_reader.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <utility>
#include <vector>

namespace cdshear {

std::string too_deep_toml_key(std::string_view text) {
  // A key, dotted or not, lies between two of these characters on one line (TOML keys never span
  // lines): after a line's start, '[', '{' or ',', before '=' or ']'. Counting the dots of each
  // stretch between them bounds every key's parts; a number has at most one dot, and two dots
  // in a row (a path's "../") belong to no key.
  constexpr std::string_view kKeyEnds = "=,{}[]#\n";
  std::size_t line = 1, dots = 0;
  char previous = '\0';
  for (const char ch : text) {
    const char before = std::exchange(previous, ch);
    if (kKeyEnds.find(ch) != std::string_view::npos || (ch == '.' && before == '.')) {
      dots = 0;
      if (ch == '\n') ++line;
    } else if (ch == '.' && ++dots >= kMaxTomlKeyParts) {
      return fmt::format("line {} holds a dotted key of more than {} parts (a.b.c has 3)", line,
                         kMaxTomlKeyParts);
    }
  }
  return {};
}

namespace {
/// The library's parse error as ours, naming the file, line and column.
ConfigError toml_syntax_error(const std::string& path, const toml::parse_error& e) {
  std::ostringstream where;
  where << "line " << e.source().begin.line << ", column " << e.source().begin.column;
  return ConfigError(path, "",
                     "TOML syntax error at " + where.str() + ": " + std::string(e.description()));
}
}  // namespace

toml::table parse_toml_file(const std::string& path) {
  if (!std::filesystem::exists(path)) throw ConfigError(path, "", "file not found");
  if (std::filesystem::is_directory(path))
    throw ConfigError(path, "", "is a directory, not a TOML file");
  if (!std::filesystem::is_regular_file(path))
    throw ConfigError(path, "", "is not a regular file (a pipe or a device?)");
  std::ifstream in(path, std::ios::binary);
  std::ostringstream read;
  read << in.rdbuf();
  if (!in) {
    try {
      return toml::parse_file(path);  // unreadable: the library names the cause
    } catch (const toml::parse_error& e) {
      throw toml_syntax_error(path, e);
    }
  }
  return parse_toml_text(std::move(read).str(), path);  // the text read once, scanned and parsed
}

toml::table parse_toml_text(const std::string& text, const std::string& path) {
  if (const std::string where = too_deep_toml_key(text); !where.empty())
    throw ConfigError(path, "", where);
  try {
    return toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    throw toml_syntax_error(path, e);
  }
}

std::string format_number(double v) {
  return fmt::format("{:.6g}", v);
}

namespace {
/// A bare word: letters, digits, '_' and '-', starting with a letter (`random`, `auto`).
bool is_bare_word(const std::string& s) {
  if (s.empty() || !std::isalpha(static_cast<unsigned char>(s[0]))) return false;
  for (const char ch : s)
    if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '_' && ch != '-') return false;
  return true;
}
}  // namespace

std::string case_key_problem(const std::string& key) {
  if (key.empty()) return "is empty";
  std::size_t start = 0;
  while (true) {
    const std::size_t dot = key.find('.', start);
    const std::string part = key.substr(start, dot == std::string::npos ? dot : dot - start);
    if (part.empty()) return "'" + key + "' has an empty part (a key is parts joined by '.')";
    for (const char ch : part)
      if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '_' && ch != '-')
        return "'" + key + "' is not a case key: its parts hold only letters, digits, '_' and '-'";
    if (dot == std::string::npos) return "";
    start = dot + 1;
  }
}

std::string override_key(const std::string& item) {
  std::string key = item.substr(0, item.find('='));
  const auto first = key.find_first_not_of(" \t");
  if (first == std::string::npos) return "";
  return key.substr(first, key.find_last_not_of(" \t") - first + 1);
}

void apply_overrides(toml::table& root, const std::vector<std::string>& overrides,
                     OverrideSources* sources, const std::string& file) {
  for (const std::string& item : overrides) {
    const auto eq = item.find('=');
    if (eq == std::string::npos || eq == 0)
      throw ConfigError("--set " + item, "", "expected key=value", override_key(item));
    const std::string key = override_key(item);
    if (const std::string problem = case_key_problem(key); !problem.empty())
      throw ConfigError("--set " + item, "", "the key " + problem, key);
    std::string value = item.substr(eq + 1);
    if (item.find_first_of("\n\r") != std::string::npos)
      throw ConfigError("--set", key, "the value holds a line break; give one key=value per --set",
                        key);
    toml::table parsed;
    try {
      parsed = toml::parse("v = " + value);
    } catch (const toml::parse_error& e) {
      if (!is_bare_word(value))
        throw ConfigError("--set " + item, key,
                          "'" + value + "' is not a TOML value (" + std::string(e.description()) +
                              "); strings other than single words need quotes: key='\"text\"'",
                          key);
      parsed = toml::parse("v = \"" + value + "\"");  // a bare word: --set solver.order=random
    }
    // A --set neither replaces nor adds nor reaches into an array of tables ([[walls]],
    // [[disks]]): its entries are not addressed one by one, and `walls=[]` would drop the file's
    // walls unseen. Checked first, so that `walls.normal={...}` is not sent to a table's advice.
    if (parsed.get("v")->is_array_of_tables())
      throw ConfigError("--set " + item, key,
                        "an array of tables ([[" + key +
                            "]]) is given in the file, not by --set: its entries cannot be "
                            "replaced or added this way",
                        key);
    for (auto dot = key.find('.');; dot = key.find('.', dot + 1)) {
      const std::string prefix = key.substr(0, dot);
      if (root.at_path(prefix).is_array_of_tables())
        throw ConfigError("--set " + item, key,
                          "an array of tables ([[" + prefix +
                              "]]) is given in the file, not by --set: its entries cannot be "
                              "replaced, added or changed this way",
                          key);
      if (dot == std::string::npos) break;
    }
    // A TOML inline table defines the whole table: `--set shear={velocity=0.4}` would drop the
    // case file's other shear keys back to their defaults, unseen. One key per --set instead.
    if (parsed.get("v")->is_table())
      throw ConfigError("--set " + item, key,
                        "a table value would replace every key of '" + key +
                            "' (the case file's included); give one key per --set: --set " + key +
                            ".KEY=VALUE",
                        key);
    if (sources != nullptr) (*sources)[key] = "--set " + item;
    toml::table* at = &root;
    std::string rest = key;
    for (auto dot = rest.find('.'); dot != std::string::npos; dot = rest.find('.')) {
      const std::string part = rest.substr(0, dot);
      rest = rest.substr(dot + 1);
      toml::node* next = at->get(part);
      if (next == nullptr) {
        at->insert(part, toml::table{});
        next = at->get(part);
      }
      if (!next->is_table()) {
        // An earlier --set that gave the table a value (`--set shear=1 --set shear.velocity=1`)
        // is the one to blame; otherwise the file gave it one.
        const std::string so_far = key.substr(0, key.size() - rest.size() - 1);
        if (sources != nullptr)
          if (const auto earlier = sources->find(so_far); earlier != sources->end())
            throw ConfigError(
                earlier->second, so_far,
                "gives '" + so_far + "' a value, so --set " + item + " cannot set a key inside it",
                so_far);
        throw ConfigError("--set " + item, key,
                          "'" + so_far + "' is not a table" +
                              (file.empty() ? std::string() : ": " + file + " gives it a value"),
                          key);
      }
      at = next->as_table();
    }
    at->insert_or_assign(rest, *parsed.get("v"));
  }
}

TomlReader::TomlReader(const toml::table& table, std::string file, std::string prefix,
                       std::shared_ptr<const OverrideSources> sources)
    : table_(&table),
      file_(std::move(file)),
      prefix_(std::move(prefix)),
      sources_(std::move(sources)) {}

TomlReader TomlReader::filling(toml::table& table, std::string file,
                               std::shared_ptr<const OverrideSources> sources) {
  TomlReader reader(table, std::move(file), "", std::move(sources));
  reader.fill_ = &table;
  return reader;
}

template <class V>
void TomlReader::fill(const std::string& key, const V& value) {
  if (fill_ != nullptr) fill_->insert_or_assign(key, value);
}

std::string TomlReader::full_key(const std::string& key) const {
  return prefix_.empty() ? key : prefix_ + "." + key;
}

std::string blamed_key(const OverrideSources* sources, std::initializer_list<std::string> keys) {
  if (sources == nullptr) return "";
  for (const std::string& full : keys) {
    if (sources->contains(full)) return full;  // the value came from the command line
    // A key that a `--set` of a key inside it made a table (`--set sheer.velocity=1`: "sheer"
    // is unknown; `--set shear.velocity.x=1`: shear.velocity is no number): that `--set`.
    const std::string inside = full + ".";
    if (const auto it = sources->lower_bound(inside);
        it != sources->end() && it->first.starts_with(inside))
      return it->first;
  }
  return "";
}

std::string blamed_source(const std::string& file, const OverrideSources* sources,
                          std::initializer_list<std::string> keys) {
  const std::string given = blamed_key(sources, keys);
  return given.empty() ? file : sources->at(given);
}

namespace {

/// Edits (insertions, deletions, substitutions) between two keys: Levenshtein's distance.
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({above + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

/// Whether `a` and `b` are sibling keys (`region_min`, `region_max`): the same up to a last '_',
/// their last parts two or more edits apart. A missing key's sibling is read on its own, not
/// misspelt (`region_mn` is one edit from `region_min`: a misspelling).
bool siblings(const std::string& a, const std::string& b) {
  const std::size_t cut = a.rfind('_');
  if (cut == std::string::npos || b.rfind('_') != cut || a.compare(0, cut, b, 0, cut) != 0)
    return false;
  return edit_distance(a.substr(cut), b.substr(cut)) >= 2;
}

}  // namespace

std::string TomlReader::near_miss(const std::string& key) const {
  // A key of this table not read so far, within a third of the key's length in edits (at least
  // two): `velocity` for `velocities`, `sytems` for `systems`.
  const std::size_t allowed = std::max<std::size_t>(2, key.size() / 3);
  std::string best;
  std::size_t best_distance = allowed + 1;
  for (const auto& [k, v] : *table_) {
    const std::string name(k.str());
    if (name == key || used_.contains(name) || siblings(name, key)) continue;
    const std::size_t d = edit_distance(name, key);
    if (d < best_distance) best = name, best_distance = d;
  }
  return best;
}

void TomlReader::fail(const std::string& key, const std::string& problem) const {
  fail_between(key, {}, problem);
}

void TomlReader::fail_missing(const std::string& key, const std::string& how) const {
  // A required key that is missing is most often misspelt: name the spelling given, in the file
  // or by a --set (which the error then blames).
  const std::string problem = "is required" + how;
  if (const std::string typo = near_miss(key); !typo.empty()) {
    const std::string typo_key = full_key(typo);
    fail_between(key, {typo_key},
                 problem + " (" + (overridden(typo_key) ? "--set" : "the file") + " gives '" +
                     typo_key + "': misspelt?)");
  }
  fail_between(key, {}, problem);
}

void TomlReader::fail_between(const std::string& key, std::initializer_list<std::string> others,
                              const std::string& problem) const {
  const std::string full = full_key(key);
  // The key's own override first, then one of the others'; else the file.
  std::string given = blamed_key(sources_.get(), {full});
  if (given.empty()) given = blamed_key(sources_.get(), others);
  throw ConfigError(given.empty() ? file_ : sources_->at(given), full, problem, given);
}

bool TomlReader::has(const std::string& key) const {
  return table_->contains(key);
}

bool TomlReader::holds_string(const std::string& key) const {
  const toml::node* node = table_->get(key);
  return node != nullptr && node->is_string();
}

bool TomlReader::has_table(const std::string& key) const {
  const toml::node* node = table_->get(key);
  return node != nullptr && node->is_table();
}

namespace {

/// Why a node is not a number: an integer that a double cannot hold exactly (beyond 2^53, which
/// toml++ will not round) or not a number at all.
std::string not_a_number(const toml::node& n) {
  if (const std::optional<std::int64_t> i = n.value<std::int64_t>(); i && n.is_integer())
    return "the integer " + std::to_string(*i) +
           ", beyond 2^53: no floating-point number holds it exactly (write it with an "
           "exponent, like 9.0e15)";
  return "must be a number";
}

}  // namespace

const toml::node* TomlReader::lookup(const std::string& key) {
  used_.insert(key);
  return table_->get(key);
}

double TomlReader::number(const std::string& key, std::optional<double> fallback) {
  const toml::node* n = lookup(key);
  if (n == nullptr) {
    if (!fallback) fail_missing(key);
    fill(key, *fallback);
    return *fallback;
  }
  if (auto v = n->value<double>(); v && (n->is_floating_point() || n->is_integer())) {
    if (!std::isfinite(*v)) fail(key, "must be a finite number");
    return *v;
  }
  fail(key, not_a_number(*n));
}

std::int64_t TomlReader::integer(const std::string& key, std::optional<std::int64_t> fallback) {
  const toml::node* n = lookup(key);
  if (n == nullptr) {
    if (!fallback) fail_missing(key);
    fill(key, *fallback);
    return *fallback;
  }
  if (!n->is_integer()) fail(key, "must be an integer");
  return *n->value<std::int64_t>();
}

std::int64_t TomlReader::integer_in(const std::string& key, std::int64_t lo, std::int64_t hi,
                                    std::optional<std::int64_t> fallback) {
  const std::int64_t v = integer(key, fallback);
  if (v < lo || v > hi)
    fail(key, "must be between " + std::to_string(lo) + " and " + std::to_string(hi) + ", got " +
                  std::to_string(v));
  return v;
}

bool TomlReader::boolean(const std::string& key, std::optional<bool> fallback) {
  const toml::node* n = lookup(key);
  if (n == nullptr) {
    if (!fallback) fail_missing(key);
    fill(key, *fallback);
    return *fallback;
  }
  if (!n->is_boolean()) fail(key, "must be true or false");
  return *n->value<bool>();
}

std::string TomlReader::string(const std::string& key, std::optional<std::string> fallback) {
  const toml::node* n = lookup(key);
  if (n == nullptr) {
    if (!fallback) fail_missing(key);
    fill(key, *fallback);
    return *fallback;
  }
  if (!n->is_string()) fail(key, "must be a string");
  std::string text = *n->value<std::string>();
  // A path is handed to the system as a C string, which ends at the first NUL: "p.json\u0000x"
  // would open p.json while the run recorded the whole string. No setting takes one.
  if (text.find('\0') != std::string::npos)
    fail(key, "holds a NUL character (\\u0000), which no setting takes");
  return text;
}

Vec2 TomlReader::vec2(const std::string& key, std::optional<Vec2> fallback) {
  const toml::node* n = lookup(key);
  if (n == nullptr) {
    if (!fallback) fail_missing(key);
    fill(key, toml::array{fallback->x, fallback->y});
    return *fallback;
  }
  const toml::array* a = n->as_array();
  if (a == nullptr || a->size() != 2 || !(*a)[0].is_number() || !(*a)[1].is_number())
    fail(key, "must be an array of two numbers, like [0.0, 1.0]");
  for (const toml::node& item : *a)
    if (!item.value<double>()) fail(key, "holds " + not_a_number(item));
  const Vec2 v{*(*a)[0].value<double>(), *(*a)[1].value<double>()};
  if (!std::isfinite(v.x) || !std::isfinite(v.y)) fail(key, "must be finite");
  return v;
}

std::vector<double> TomlReader::number_array(const std::string& key) {
  const toml::node* n = lookup(key);
  if (n == nullptr) fail_missing(key);
  const toml::array* a = n->as_array();
  if (a == nullptr) fail(key, "must be an array of numbers, like [5.0, 10.0]");
  std::vector<double> out;
  for (const toml::node& item : *a) {
    if (!item.is_number()) fail(key, "must be an array of numbers, like [5.0, 10.0]");
    const std::optional<double> v = item.value<double>();
    if (!v) fail(key, "holds " + not_a_number(item));
    out.push_back(*v);
  }
  return out;
}

std::vector<std::int64_t> TomlReader::integer_array(const std::string& key, std::int64_t lo,
                                                    std::int64_t hi) {
  const toml::node* n = lookup(key);
  if (n == nullptr) fail_missing(key);
  const toml::array* a = n->as_array();
  if (a == nullptr) fail(key, "must be an array of whole numbers, like [1, 2]");
  std::vector<std::int64_t> out;
  for (const toml::node& item : *a) {
    if (!item.is_integer()) fail(key, "must be an array of whole numbers, like [1, 2]");
    const std::int64_t v = *item.value<std::int64_t>();
    if (v < lo || v > hi)
      fail(key, "every entry must be between " + std::to_string(lo) + " and " + std::to_string(hi) +
                    ", got " + std::to_string(v));
    out.push_back(v);
  }
  return out;
}

double TomlReader::positive(const std::string& key, std::optional<double> fallback) {
  const double v = number(key, fallback);
  if (!(v > 0.0)) fail(key, "must be > 0, got " + format_number(v));
  return v;
}

double TomlReader::non_negative(const std::string& key, std::optional<double> fallback) {
  const double v = number(key, fallback);
  if (!(v >= 0.0)) fail(key, "must be >= 0, got " + format_number(v));
  return v;
}

std::string TomlReader::choice(const std::string& key, const std::vector<std::string>& choices,
                               std::optional<std::string> fallback) {
  const std::string v = string(key, std::move(fallback));
  for (const auto& c : choices)
    if (c == v) return v;
  std::string list;
  for (const auto& c : choices) list += (list.empty() ? "" : ", ") + ("'" + c + "'");
  fail(key, "must be one of " + list + ", got '" + v + "'");
}

TomlReader TomlReader::table(const std::string& key) {
  static const toml::table empty;
  const toml::node* n = lookup(key);
  if (n != nullptr && !n->is_table()) fail(key, "must be a table");
  if (fill_ != nullptr) {  // the sub-table, made where absent, filled in turn
    if (n == nullptr) fill_->insert(key, toml::table{});
    toml::table& sub = *fill_->get_as<toml::table>(key);
    TomlReader reader(sub, file_, full_key(key), sources_);
    reader.fill_ = &sub;
    return reader;
  }
  return TomlReader(n == nullptr ? empty : *n->as_table(), file_, full_key(key), sources_);
}

std::vector<TomlReader> TomlReader::tables(const std::string& key) {
  std::vector<TomlReader> out;
  const toml::node* n = lookup(key);
  if (n == nullptr) return out;
  const toml::array* a = n->as_array();
  if (a == nullptr) fail(key, "must be an array of tables ([[" + full_key(key) + "]])");
  for (std::size_t i = 0; i < a->size(); ++i) {
    const toml::table* t = (*a)[i].as_table();
    if (t == nullptr) fail(key, "entry " + std::to_string(i) + " must be a table");
    out.emplace_back(*t, file_, full_key(key) + "[" + std::to_string(i) + "]", sources_);
    if (fill_ != nullptr)
      out.back().fill_ = fill_->get_as<toml::array>(key)->get_as<toml::table>(i);
  }
  return out;
}

void TomlReader::finish() const {
  for (const auto& [k, v] : *table_) {
    const std::string name(k.str());
    if (!used_.contains(name)) fail(name, "unknown key");
  }
}

}  // namespace cdshear
