#include "checkpoint.hpp"

#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "config_error.hpp"
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
    error_ = e.what();
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
std::vector<Vec2> vec2s(const json& x, const json& y) {
  const auto xs = x.get<std::vector<double>>(), ys = y.get<std::vector<double>>();
  std::vector<Vec2> out(xs.size());
  for (std::size_t i = 0; i < xs.size(); ++i) out[i] = {xs[i], ys.at(i)};
  return out;
}
json to_json(Vec2 v) {
  return json::array({v.x, v.y});
}
Vec2 to_vec2(const json& j) {
  return {j.at(0).get<double>(), j.at(1).get<double>()};
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

/// Every field checked like an input file: finite numbers, positive sizes, known modes, contact
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
    for (const AxisMode m : {wall.mode_x, wall.mode_y})
      if (m != AxisMode::kFixed && m != AxisMode::kImposed && m != AxisMode::kFree)
        fail(at + ".mode", "unknown wall mode " + std::to_string(static_cast<int>(m)));
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
    if (c.key.body_a < 0 || c.key.body_a >= n || c.key.body_b < 0 || c.key.body_b >= bodies ||
        c.key.body_a == c.key.body_b)
      fail("contacts[" + std::to_string(k) + "]", "body index out of range");
    if (!std::isfinite(c.impulse_n) || !std::isfinite(c.impulse_t) || c.impulse_n < 0)
      fail("contacts[" + std::to_string(k) + "]", "impulses must be finite, normal >= 0");
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
  try {
    const json j = parse_bounded_cbor(body, file);
    if (!j.is_object() || !j.contains("format") || j.at("format") != "cdshear-checkpoint")
      throw ConfigError(file, "format", "not a cdshear checkpoint");
    if (j.at("version") != 1)
      throw ConfigError(file, "version",
                        "unsupported checkpoint version " + j.at("version").dump());
    World& w = cp.world;
    w.time = j.at("time").get<double>();
    w.step = j.at("step").get<std::uint64_t>();
    w.domain.periodic_x = j.at("periodic_x").get<bool>();
    w.domain.length_x = j.at("length_x").get<double>();
    w.body_force = to_vec2(j.at("body_force"));
    w.friction_disk_disk = j.at("friction_disk_disk").get<double>();
    const json& d = j.at("disks");
    w.disks.position = vec2s(d.at("x"), d.at("y"));
    w.disks.image = d.at("image").get<std::vector<std::int64_t>>();
    w.disks.angle = d.at("angle").get<std::vector<double>>();
    w.disks.velocity = vec2s(d.at("vx"), d.at("vy"));
    w.disks.omega = d.at("omega").get<std::vector<double>>();
    w.disks.radius = d.at("radius").get<std::vector<double>>();
    w.disks.mass = d.at("mass").get<std::vector<double>>();
    w.disks.inertia = d.at("inertia").get<std::vector<double>>();
    for (const json& wj : j.at("walls")) {
      Wall wall;
      wall.name = wj.at("name").get<std::string>();
      wall.point = to_vec2(wj.at("point"));
      wall.normal = to_vec2(wj.at("normal"));
      wall.mode_x = static_cast<AxisMode>(wj.at("mode_x").get<int>());
      wall.mode_y = static_cast<AxisMode>(wj.at("mode_y").get<int>());
      wall.velocity = to_vec2(wj.at("velocity"));
      wall.mass = wj.at("mass").get<double>();
      wall.applied_force = to_vec2(wj.at("applied_force"));
      wall.friction = wj.at("friction").get<double>();
      wall.contact_force = to_vec2(wj.at("contact_force"));
      wall.contact_impulse = to_vec2(wj.at("contact_impulse"));
      w.walls.push_back(wall);
    }
    if (j.contains("observers")) cp.observers = j.at("observers");
    if (j.contains("case")) cp.case_identity = j.at("case");
    if (j.contains("instruction_set")) {
      if (!j.at("instruction_set").is_string())
        throw ConfigError(file, "instruction_set", "must be a string");
      cp.instruction_set = j.at("instruction_set").get<std::string>();
    }
    const json& c = j.at("contacts");
    const auto a = c.at("a").get<std::vector<std::int32_t>>();
    const auto b = c.at("b").get<std::vector<std::int32_t>>();
    const auto image = c.at("image").get<std::vector<std::int32_t>>();
    const auto rn = c.at("rn").get<std::vector<double>>();
    const auto rt = c.at("rt").get<std::vector<double>>();
    for (std::size_t k = 0; k < a.size(); ++k) {
      Contact con;
      con.key = {a[k], b.at(k), image.at(k)};
      con.impulse_n = rn.at(k);
      con.impulse_t = rt.at(k);
      cp.contacts.push_back(con);
    }
    const std::size_t n = w.disks.position.size();
    for (const std::size_t size :
         {w.disks.image.size(), w.disks.angle.size(), w.disks.velocity.size(), w.disks.omega.size(),
          w.disks.radius.size(), w.disks.mass.size(), w.disks.inertia.size()})
      if (size != n) throw ConfigError(file, "disks", "arrays of different lengths");
    validate(cp, file);
  } catch (const ConfigError&) {
    throw;
  } catch (const std::exception& e) {
    throw ConfigError(file, "", std::string("corrupt checkpoint: ") + e.what());
  }
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
