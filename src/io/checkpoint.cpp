#include "checkpoint.hpp"

#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <limits>
#include <nlohmann/json.hpp>

#include "config_error.hpp"
#include "json_reading.hpp"
#include "outputs.hpp"

namespace cdshear {
namespace {

using nlohmann::json;

/// How deep a checkpoint's CBOR may nest. A checkpoint nests a few levels (the measurement's state
/// the deepest); nlohmann's CBOR reader recurses once per level, so a crafted file of a few
/// hundred thousand nested arrays behind a correct seal would exhaust the stack.
constexpr std::size_t kMaxCborDepth = 64;

/// A DOM builder for nlohmann's SAX interface with a bound on nesting: past kMaxCborDepth,
/// start_object and start_array answer false, which stops the reader before it recurses further.
/// Written here rather than derived from nlohmann's own builder, whose class is internal to the
/// library (its template parameters differ between versions).
class BoundedDomBuilder {
 public:
  explicit BoundedDomBuilder(json& root) : root_(root) {}
  bool null() { return put(nullptr); }
  bool boolean(bool v) { return put(v); }
  bool number_integer(json::number_integer_t v) { return put(v); }
  bool number_unsigned(json::number_unsigned_t v) { return put(v); }
  bool number_float(json::number_float_t v, const json::string_t&) { return put(v); }
  bool string(json::string_t& v) { return put(std::move(v)); }
  bool binary(json::binary_t& v) { return put(json::binary(std::move(v))); }
  bool start_object(std::size_t) { return open(json::object()); }
  bool key(json::string_t& k) {
    key_ = std::move(k);
    return true;
  }
  bool end_object() { return close(); }
  bool start_array(std::size_t) { return open(json::array()); }
  bool end_array() { return close(); }
  bool parse_error(std::size_t, const std::string&, const json::exception& e) {
    error_ = json_message(e);
    return false;
  }
  bool too_deep() const { return too_deep_; }
  const std::string& error() const { return error_; }

 private:
  /// Where the next value goes: the root, the open array's end, or the open object's key.
  json& slot() {
    if (open_.empty()) return root_;
    json& top = *open_.back();
    if (top.is_array()) {
      top.push_back(nullptr);
      return top.back();
    }
    return top[key_];
  }
  bool put(json&& v) {
    slot() = std::move(v);
    return true;
  }
  bool open(json&& container) {
    if (open_.size() >= kMaxCborDepth) {
      too_deep_ = true;
      return false;
    }
    json& s = slot();
    s = std::move(container);
    open_.push_back(&s);
    return true;
  }
  bool close() {
    open_.pop_back();
    return true;
  }
  json& root_;
  std::vector<json*> open_;  ///< the containers being filled, outermost first
  json::string_t key_;
  bool too_deep_ = false;
  std::string error_;
};

/// The CBOR of a checkpoint's body, nested at most kMaxCborDepth levels (else a ConfigError naming
/// `file`); nlohmann's parse errors pass through.
json parse_bounded_cbor(const std::vector<std::uint8_t>& body, const std::string& file) {
  json j;
  BoundedDomBuilder builder(j);
  const bool parsed = json::sax_parse(body, &builder, json::input_format_t::cbor);
  if (builder.too_deep())
    throw ConfigError(
        file, "",
        fmt::format("nests deeper than {} levels: not a checkpoint cdshear wrote", kMaxCborDepth));
  if (!parsed)
    throw ConfigError(file, "",
                      "corrupt checkpoint: " +
                          (builder.error().empty() ? std::string("not CBOR") : builder.error()));
  return j;
}

json xy(const std::vector<Vec2>& v, bool take_y) {
  std::vector<double> out(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) out[i] = take_y ? v[i].y : v[i].x;
  return out;
}
json to_json(Vec2 v) {
  return json::array({v.x, v.y});
}

/// The seal line in front of the CBOR: its CRC-32 (zlib) and size. Checked before the CBOR
/// parser sees a byte: the fuzzer found that nlohmann-json's CBOR reader recurses without bound
/// on deeply nested arrays (a stack overflow), and a damaged file that still parses would
/// otherwise resume with other numbers.
constexpr char kSealPrefix[] = "cdshear-checkpoint crc32=";

std::string seal_line(const std::vector<std::uint8_t>& body) {
  const uLong crc = crc32(crc32(0L, Z_NULL, 0), body.data(), static_cast<uInt>(body.size()));
  char line[96];
  std::snprintf(line, sizeof line, "%s%08lx size=%zu\n", kSealPrefix, crc, body.size());
  return line;
}

/// Typed reads of a checkpoint's fields: a field that is missing or of another type is named by
/// its path (`disks.vx`, `walls[1].mass`, `contacts.rn[7]`) with the type it must have, never by
/// the JSON library's words.
struct CheckpointFields {
  const std::string& file;

  const json& at(const json& parent, const std::string& prefix, const char* key) const {
    if (!parent.is_object())
      throw ConfigError(file, prefix.empty() ? "" : prefix.substr(0, prefix.size() - 1),
                        "must be a table");
    const auto it = parent.find(key);
    if (it == parent.end()) throw ConfigError(file, prefix + key, "is missing");
    return *it;
  }
  double number(const json& v, const std::string& path) const {
    if (!v.is_number()) throw ConfigError(file, path, "must be a number, not " + json_shown(v));
    return v.get<double>();
  }
  Vec2 vec2(const json& v, const std::string& path) const {
    if (!v.is_array() || v.size() != 2 || !v[0].is_number() || !v[1].is_number())
      throw ConfigError(file, path, "must be two numbers [x, y], not " + json_shown(v));
    return {v[0].get<double>(), v[1].get<double>()};
  }
  /// A list of numbers.
  std::vector<double> numbers(const json& v, const std::string& path) const {
    if (!v.is_array()) throw ConfigError(file, path, "must be a list of numbers");
    std::vector<double> out;
    out.reserve(v.size());
    for (std::size_t i = 0; i < v.size(); ++i)  // the path formatted only for a message
      out.push_back(v[i].is_number() ? v[i].get<double>()
                                     : number(v[i], fmt::format("{}[{}]", path, i)));
    return out;
  }
  /// A whole number from `low` to `high`.
  static bool whole_in(const json& v, std::int64_t low, std::int64_t high) {
    return v.is_number_unsigned() ? v.get<std::uint64_t>() <= static_cast<std::uint64_t>(high)
                                  : v.is_number_integer() && v.get<std::int64_t>() >= low &&
                                        v.get<std::int64_t>() <= high;
  }
  std::int64_t integer(const json& v, const std::string& path, std::int64_t low,
                       std::int64_t high) const {
    if (!whole_in(v, low, high))
      throw ConfigError(
          file, path,
          fmt::format("must be a whole number from {} to {}, not {}", low, high, json_shown(v)));
    return v.is_number_unsigned() ? static_cast<std::int64_t>(v.get<std::uint64_t>())
                                  : v.get<std::int64_t>();
  }
  /// A list of whole numbers from `low` to `high`.
  std::vector<std::int64_t> integers(const json& v, const std::string& path, std::int64_t low,
                                     std::int64_t high) const {
    if (!v.is_array()) throw ConfigError(file, path, "must be a list of whole numbers");
    std::vector<std::int64_t> out;
    out.reserve(v.size());
    for (std::size_t i = 0; i < v.size(); ++i)  // the path formatted only for a message
      out.push_back(integer(v[i], whole_in(v[i], low, high) ? path : fmt::format("{}[{}]", path, i),
                            low, high));
    return out;
  }
};

/// Every field checked like an input file: finite numbers, positive sizes, contact
/// indices in range. Names the first bad field.
void validate(const Checkpoint& cp, const std::string& file) {
  const World& w = cp.world;
  const auto fail = [&file](const std::string& key, const std::string& problem) {
    throw ConfigError(file, key, problem);
  };
  const auto finite = [](Vec2 v) { return std::isfinite(v.x) && std::isfinite(v.y); };
  if (!std::isfinite(w.time) || w.time < 0) fail("time", "must be finite and >= 0");
  if (w.domain.periodic_x && !(w.domain.length_x > 0 && std::isfinite(w.domain.length_x)))
    fail("length_x", "must be > 0 when x is periodic");
  if (!finite(w.body_force)) fail("body_force", "must be finite");
  if (!(w.friction_disk_disk >= 0)) fail("friction_disk_disk", "must be >= 0");
  const Disks& d = w.disks;
  for (std::size_t i = 0; i < d.size(); ++i) {
    const std::string at = "[" + std::to_string(i) + "]";
    if (!finite(d.position[i]) || !finite(d.velocity[i]) || !std::isfinite(d.omega[i]) ||
        !std::isfinite(d.angle[i]))
      fail("disks" + at, "position, velocity, angle and omega must be finite");
    if (!(d.radius[i] > 0) || !(d.mass[i] > 0) || !(d.inertia[i] > 0) ||
        !std::isfinite(d.radius[i] + d.mass[i] + d.inertia[i]))
      fail("disks" + at, "radius, mass and inertia must be finite and > 0");
  }
  for (std::size_t k = 0; k < w.walls.size(); ++k) {
    const Wall& wall = w.walls[k];
    const std::string at = "walls[" + std::to_string(k) + "]";
    if (!finite(wall.point) || !finite(wall.velocity) || !finite(wall.applied_force) ||
        !finite(wall.contact_impulse) || !finite(wall.contact_force))
      fail(at, "every vector must be finite");
    if (std::abs(length(wall.normal) - 1.0) > 1e-9) fail(at + ".normal", "must be a unit vector");
    if ((wall.mode_x == AxisMode::kFree || wall.mode_y == AxisMode::kFree) && !(wall.mass > 0))
      fail(at + ".mass", "must be > 0 on a free axis");
    if (!(wall.friction >= 0)) fail(at + ".friction", "must be >= 0");
  }
  const auto n = static_cast<std::int64_t>(d.size());
  const auto bodies = n + static_cast<std::int64_t>(w.walls.size());
  for (std::size_t k = 0; k < cp.contacts.size(); ++k) {
    const Contact& c = cp.contacts[k];
    // Body a is a disk (0 to n - 1), body b a disk or a wall (n to n + walls - 1). The counts
    // are named: an index past them is often a list of disks or walls cut short, not the contact.
    const bool a_bad = c.key.body_a < 0 || c.key.body_a >= n;
    if (a_bad || c.key.body_b < 0 || c.key.body_b >= bodies || c.key.body_a == c.key.body_b)
      fail(fmt::format("contacts.{}[{}]", a_bad ? 'a' : 'b', k),
           fmt::format("joins bodies {} and {}, where the checkpoint holds {} disks (bodies 0 to "
                       "{}) and {}: body a must be a disk, body b another disk or a wall",
                       c.key.body_a, c.key.body_b, n, n - 1,
                       w.walls.empty() ? std::string("no walls")
                                       : fmt::format("{} walls (bodies {} to {})", w.walls.size(),
                                                     n, bodies - 1)));
    if (!std::isfinite(c.impulse_n) || !std::isfinite(c.impulse_t) || c.impulse_n < 0)
      fail("contacts[" + std::to_string(k) + "]", "impulses must be finite, normal >= 0");
    // The list is kept sorted by key (the warm start merges by it): a contact repeated or out of
    // order would be warm-started twice or not at all.
    if (k > 0 && !(cp.contacts[k - 1].key < c.key))
      fail(fmt::format("contacts[{}]", k),
           fmt::format("the contact of bodies {} and {} (image {}) comes again or out of order: a "
                       "checkpoint lists each contact once, ordered by bodies and image",
                       c.key.body_a, c.key.body_b, c.key.image_b));
  }
}

}  // namespace

void write_checkpoint(const std::filesystem::path& path, const World& w,
                      const std::vector<Contact>& contacts, const json& observers,
                      const json& case_identity, const std::string& instruction_set) {
  const Disks& d = w.disks;
  json walls = json::array();
  for (const Wall& wall : w.walls)
    walls.push_back({{"name", wall.name},
                     {"point", to_json(wall.point)},
                     {"normal", to_json(wall.normal)},
                     {"mode_x", static_cast<int>(wall.mode_x)},
                     {"mode_y", static_cast<int>(wall.mode_y)},
                     {"velocity", to_json(wall.velocity)},
                     {"mass", wall.mass},
                     {"applied_force", to_json(wall.applied_force)},
                     {"friction", wall.friction},
                     {"contact_force", to_json(wall.contact_force)},
                     {"contact_impulse", to_json(wall.contact_impulse)}});
  std::vector<std::int32_t> a, b, image;
  std::vector<double> rn, rt;
  for (const Contact& c : contacts) {
    a.push_back(c.key.body_a);
    b.push_back(c.key.body_b);
    image.push_back(c.key.image_b);
    rn.push_back(c.impulse_n);
    rt.push_back(c.impulse_t);
  }
  json j = {{"format", "cdshear-checkpoint"},
            {"version", 1},
            {"program_version", CDSHEAR_VERSION},
            {"instruction_set", instruction_set},
            {"time", w.time},
            {"step", w.step},
            {"periodic_x", w.domain.periodic_x},
            {"length_x", w.domain.length_x},
            {"body_force", to_json(w.body_force)},
            {"friction_disk_disk", w.friction_disk_disk},
            {"disks",
             {{"x", xy(d.position, false)},
              {"y", xy(d.position, true)},
              {"image", d.image},
              {"angle", d.angle},
              {"vx", xy(d.velocity, false)},
              {"vy", xy(d.velocity, true)},
              {"omega", d.omega},
              {"radius", d.radius},
              {"mass", d.mass},
              {"inertia", d.inertia}}},
            {"walls", walls},
            {"contacts", {{"a", a}, {"b", b}, {"image", image}, {"rn", rn}, {"rt", rt}}}};
  if (!observers.is_null()) j["observers"] = observers;
  if (!case_identity.is_null()) j["case"] = case_identity;
  const std::vector<std::uint8_t> body = json::to_cbor(j);
  write_file_atomic(path, seal_line(body) + std::string(body.begin(), body.end()));
}

Checkpoint read_checkpoint(const std::filesystem::path& path) {
  const std::string file = path.string();
  // A FIFO or a device would block the open until a writer appears: refuse anything but a file.
  if (std::filesystem::exists(path) && !std::filesystem::is_regular_file(path))
    throw ConfigError(file, "", "is not a regular file (a pipe, a device or a folder?)");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(file, "", "checkpoint not found");
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                        std::istreambuf_iterator<char>());
  // The seal: "cdshear-checkpoint crc32=XXXXXXXX size=N\n", then N bytes of CBOR.
  const auto newline =
      std::find(bytes.begin(), bytes.begin() + std::min<std::size_t>(bytes.size(), 96), '\n');
  const std::string line(bytes.begin(), newline);
  const std::vector<std::uint8_t> body(newline == bytes.end() ? bytes.end() : newline + 1,
                                       bytes.end());
  if (line.rfind(kSealPrefix, 0) != 0 || newline == bytes.end())
    throw ConfigError(file, "",
                      "not a cdshear checkpoint (no seal line; written by another "
                      "version, or damaged)");
  if (line + "\n" != seal_line(body))
    throw ConfigError(file, "checksum",
                      "does not match the content: the file was changed or damaged after it "
                      "was written");
  Checkpoint cp;
  const json j = parse_bounded_cbor(body, file);
  const CheckpointFields f{file};
  if (!j.is_object() || !j.contains("format") || j.at("format") != "cdshear-checkpoint")
    throw ConfigError(file, "format", "not a cdshear checkpoint");
  if (f.at(j, "", "version") != 1)
    throw ConfigError(file, "version",
                      "unsupported checkpoint version " + json_shown(j.at("version")));
  World& w = cp.world;
  w.time = f.number(f.at(j, "", "time"), "time");
  const json& step = f.at(j, "", "step");
  if (!step.is_number_unsigned())
    throw ConfigError(file, "step", "must be a whole number >= 0, not " + json_shown(step));
  w.step = step.get<std::uint64_t>();
  const json& periodic = f.at(j, "", "periodic_x");
  if (!periodic.is_boolean())
    throw ConfigError(file, "periodic_x", "must be true or false, not " + json_shown(periodic));
  w.domain.periodic_x = periodic.get<bool>();
  w.domain.length_x = f.number(f.at(j, "", "length_x"), "length_x");
  w.body_force = f.vec2(f.at(j, "", "body_force"), "body_force");
  w.friction_disk_disk = f.number(f.at(j, "", "friction_disk_disk"), "friction_disk_disk");
  // The disks: ten lists of one length, that of disks.x.
  const json& d = f.at(j, "", "disks");
  const auto list = [&](const char* key) {
    return f.numbers(f.at(d, "disks.", key), std::string("disks.") + key);
  };
  const std::vector<double> x = list("x"), y = list("y"), vx = list("vx"), vy = list("vy");
  const std::size_t n = x.size();
  const auto same_length = [&](const char* key, std::size_t size) {
    if (size != n)
      throw ConfigError(file, std::string("disks.") + key,
                        fmt::format("has {} values where disks.x has {}", size, n));
  };
  for (const auto& [key, values] : {std::pair{"y", &y}, {"vx", &vx}, {"vy", &vy}})
    same_length(key, values->size());
  for (std::size_t i = 0; i < n; ++i) {
    w.disks.position.push_back({x[i], y[i]});
    w.disks.velocity.push_back({vx[i], vy[i]});
  }
  for (const auto& [key, target] : {std::pair{"angle", &w.disks.angle},
                                    {"omega", &w.disks.omega},
                                    {"radius", &w.disks.radius},
                                    {"mass", &w.disks.mass},
                                    {"inertia", &w.disks.inertia}}) {
    *target = list(key);
    same_length(key, target->size());
  }
  for (const std::int64_t image : f.integers(f.at(d, "disks.", "image"), "disks.image",
                                             std::numeric_limits<std::int64_t>::min(),
                                             std::numeric_limits<std::int64_t>::max()))
    w.disks.image.push_back(image);
  same_length("image", w.disks.image.size());
  const json& walls = f.at(j, "", "walls");
  if (!walls.is_array()) throw ConfigError(file, "walls", "must be a list of walls");
  for (std::size_t k = 0; k < walls.size(); ++k) {
    const json& wj = walls[k];
    const std::string at = fmt::format("walls[{}].", k);
    if (!wj.is_object()) throw ConfigError(file, fmt::format("walls[{}]", k), "must be a table");
    Wall wall;
    const json& name = f.at(wj, at, "name");
    if (!name.is_string()) throw ConfigError(file, at + "name", "must be a string");
    wall.name = name.get<std::string>();
    const auto vec2 = [&](const char* key) { return f.vec2(f.at(wj, at, key), at + key); };
    const auto number = [&](const char* key) { return f.number(f.at(wj, at, key), at + key); };
    const auto mode = [&](const char* key) {
      constexpr auto kFixed = static_cast<std::int64_t>(AxisMode::kFixed);  // the first mode
      constexpr auto kFree = static_cast<std::int64_t>(AxisMode::kFree);    // the last
      return static_cast<AxisMode>(f.integer(f.at(wj, at, key), at + key, kFixed, kFree));
    };
    wall.point = vec2("point");
    wall.normal = vec2("normal");
    wall.mode_x = mode("mode_x");
    wall.mode_y = mode("mode_y");
    wall.velocity = vec2("velocity");
    wall.mass = number("mass");
    wall.applied_force = vec2("applied_force");
    wall.friction = number("friction");
    wall.contact_force = vec2("contact_force");
    wall.contact_impulse = vec2("contact_impulse");
    w.walls.push_back(wall);
  }
  if (j.contains("observers")) cp.observers = j.at("observers");
  if (j.contains("case")) cp.case_identity = j.at("case");
  if (j.contains("instruction_set")) {
    if (!j.at("instruction_set").is_string())
      throw ConfigError(file, "instruction_set", "must be a string");
    cp.instruction_set = j.at("instruction_set").get<std::string>();
  }
  // The contacts: five lists of one length, that of contacts.a; body indices as stored (int32),
  // their range checked by validate.
  const json& c = f.at(j, "", "contacts");
  constexpr std::int64_t kLow = std::numeric_limits<std::int32_t>::min();
  constexpr std::int64_t kHigh = std::numeric_limits<std::int32_t>::max();
  const auto a = f.integers(f.at(c, "contacts.", "a"), "contacts.a", kLow, kHigh);
  const auto b = f.integers(f.at(c, "contacts.", "b"), "contacts.b", kLow, kHigh);
  const auto image = f.integers(f.at(c, "contacts.", "image"), "contacts.image", kLow, kHigh);
  const auto rn = f.numbers(f.at(c, "contacts.", "rn"), "contacts.rn");
  const auto rt = f.numbers(f.at(c, "contacts.", "rt"), "contacts.rt");
  for (const auto& [key, size] :
       {std::pair{"b", b.size()}, {"image", image.size()}, {"rn", rn.size()}, {"rt", rt.size()}})
    if (size != a.size())
      throw ConfigError(file, std::string("contacts.") + key,
                        fmt::format("has {} values where contacts.a has {}", size, a.size()));
  for (std::size_t k = 0; k < a.size(); ++k) {
    Contact con;
    con.key = {static_cast<std::int32_t>(a[k]), static_cast<std::int32_t>(b[k]),
               static_cast<std::int32_t>(image[k])};
    con.impulse_n = rn[k];
    con.impulse_t = rt[k];
    cp.contacts.push_back(con);
  }
  validate(cp, file);
  return cp;
}

bool same_rounding(const std::string& a, const std::string& b) {
  const auto without_fma = [](const std::string& set) {
    return set == "default" || set == "x86-64-v3-solver-nofma";
  };
  return a == b || (without_fma(a) && without_fma(b));
}

std::string instruction_set_warning(const Checkpoint& cp, const std::string& file,
                                    const std::string& this_build) {
  if (cp.instruction_set.empty() || same_rounding(cp.instruction_set, this_build)) return {};
  // "default" is CMakeLists.txt's name for the compiler's default (the x86-64 baseline).
  const auto named = [](const std::string& set) {
    return set == "default" ? std::string("the compiler's default instruction set")
                            : "the instruction set " + set;
  };
  return "warning: " + file + " was written by a cdshear built for " + named(cp.instruction_set) +
         ", this one is built for " + named(this_build) +
         ": the run goes on, but it rounds differently from here, so it is another realisation " +
         "of the flow, not the one the first build would have continued bit for bit " +
         "(docs/performance.md, \"Fused multiply-add\")";
}

}  // namespace cdshear
