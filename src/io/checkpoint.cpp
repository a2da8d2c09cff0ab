#include "checkpoint.hpp"

#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "config_error.hpp"
#include "outputs.hpp"

namespace cdshear {
namespace {

using nlohmann::json;

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

}  // namespace

void write_checkpoint(const std::filesystem::path& path, const World& w,
                      const std::vector<Contact>& contacts, const json& observers) {
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
  const std::vector<std::uint8_t> bytes = json::to_cbor(j);
  write_file_atomic(path, std::string(bytes.begin(), bytes.end()));
}

Checkpoint read_checkpoint(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(file, "", "checkpoint not found");
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                        std::istreambuf_iterator<char>());
  Checkpoint cp;
  try {
    const json j = json::from_cbor(bytes);
    if (j.at("format") != "cdshear-checkpoint")
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
    for (const Contact& con : cp.contacts)
      if (con.key.body_a < 0 || static_cast<std::size_t>(con.key.body_b) >= n + w.walls.size())
        throw ConfigError(file, "contacts", "body index out of range");
  } catch (const ConfigError&) {
    throw;
  } catch (const std::exception& e) {
    throw ConfigError(file, "", std::string("corrupt checkpoint: ") + e.what());
  }
  return cp;
}

}  // namespace cdshear
