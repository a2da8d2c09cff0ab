#include "vtk_writer.hpp"

#include <fmt/format.h>

#include <cmath>

#include "outputs.hpp"

namespace cdshear {
namespace {

std::string header(std::size_t points, const char* cells_tag, std::size_t cells) {
  return fmt::format(
      "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" "
      "byte_order=\"LittleEndian\">\n<PolyData>\n<Piece NumberOfPoints=\"{}\" "
      "NumberOfVerts=\"{}\" NumberOfLines=\"{}\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">\n",
      points, std::string(cells_tag) == "Verts" ? cells : 0,
      std::string(cells_tag) == "Lines" ? cells : 0);
}

std::string cells(const char* tag, std::size_t count, std::size_t points_per_cell) {
  std::string s = fmt::format("<{}>\n<DataArray type=\"Int32\" Name=\"connectivity\">\n", tag);
  for (std::size_t k = 0; k < count * points_per_cell; ++k) s += fmt::format("{} ", k);
  s += "\n</DataArray>\n<DataArray type=\"Int32\" Name=\"offsets\">\n";
  for (std::size_t k = 1; k <= count; ++k) s += fmt::format("{} ", k * points_per_cell);
  s += fmt::format("\n</DataArray>\n</{}>\n", tag);
  return s;
}

template <class F>
std::string array(const char* name, int components, std::size_t count, F value) {
  std::string s = fmt::format(
      "<DataArray type=\"Float64\" Name=\"{}\" NumberOfComponents=\"{}\" format=\"ascii\">\n", name,
      components);
  for (std::size_t k = 0; k < count; ++k) s += value(k) + ' ';
  return s + "\n</DataArray>\n";
}

constexpr const char* kFooter = "</Piece>\n</PolyData>\n</VTKFile>\n";

}  // namespace

void write_particles_vtp(const std::filesystem::path& path, const World& world,
                         const std::vector<Contact>& contacts) {
  const Disks& d = world.disks;
  const std::size_t n = d.size();
  std::vector<int> count(n, 0);
  for (const Contact& c : contacts) {
    if (c.impulse_n <= 0.0) continue;
    ++count[c.key.body_a];
    if (static_cast<std::size_t>(c.key.body_b) < n) ++count[c.key.body_b];
  }
  std::string s = header(n, "Verts", n);
  s += "<Points>\n" +
       array("Points", 3, n,
             [&](std::size_t i) {
               return fmt::format("{} {} 0", d.position[i].x, d.position[i].y);
             }) +
       "</Points>\n";
  s += cells("Verts", n, 1);
  s += "<PointData Scalars=\"radius\" Vectors=\"velocity\">\n";
  s += array("radius", 1, n, [&](std::size_t i) { return fmt::format("{}", d.radius[i]); });
  s += array("velocity", 3, n, [&](std::size_t i) {
    return fmt::format("{} {} 0", d.velocity[i].x, d.velocity[i].y);
  });
  s += array("omega", 1, n, [&](std::size_t i) { return fmt::format("{}", d.omega[i]); });
  s += array("contact_count", 1, n, [&](std::size_t i) { return fmt::format("{}", count[i]); });
  s += "</PointData>\n";
  write_file_atomic(path, s + kFooter);
}

void write_contacts_vtp(const std::filesystem::path& path, const World& world,
                        const std::vector<Contact>& contacts, double dt) {
  const Disks& d = world.disks;
  const std::size_t n = d.size();
  std::vector<const Contact*> active;
  for (const Contact& c : contacts)
    if (c.impulse_n > 0.0) active.push_back(&c);
  const std::size_t m = active.size();
  std::string s = header(2 * m, "Lines", m);
  s += "<Points>\n" +
       array("Points", 3, m,
             [&](std::size_t k) {
               const Contact& c = *active[k];
               const Vec2 a = d.position[c.key.body_a];
               const std::size_t b = static_cast<std::size_t>(c.key.body_b);
               // b's centre in a's frame (nearest periodic image), or the contact point on a wall.
               Vec2 end = a - d.radius[c.key.body_a] * c.normal;
               if (b < n) end = a + world.domain.minimum_image(d.position[b] - a);
               return fmt::format("{} {} 0 {} {} 0", a.x, a.y, end.x, end.y);
             }) +
       "</Points>\n";
  s += cells("Lines", m, 2);
  s += "<CellData Scalars=\"normal_force\">\n";
  s += array("normal_force", 1, m,
             [&](std::size_t k) { return fmt::format("{}", active[k]->impulse_n / dt); });
  s += array("tangential_force", 1, m,
             [&](std::size_t k) { return fmt::format("{}", active[k]->impulse_t / dt); });
  s += "</CellData>\n";
  write_file_atomic(path, s + kFooter);
}

void write_pvd(const std::filesystem::path& path, const std::vector<PvdEntry>& entries) {
  std::string s =
      "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n<Collection>\n";
  for (const PvdEntry& e : entries)
    s += fmt::format("<DataSet timestep=\"{}\" file=\"{}\"/>\n", e.time, e.file);
  write_file_atomic(path, s + "</Collection>\n</VTKFile>\n");
}

}  // namespace cdshear
