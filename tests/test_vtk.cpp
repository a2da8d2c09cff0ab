// ParaView snapshots (src/io/vtk_writer): the written values against the ones put in, for two
// disks in contact across the periodic boundary and one on the floor.
#include <gtest/gtest.h>

#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "test_support.hpp"
#include "vtk_writer.hpp"

namespace cdshear {
namespace {

/// The numbers of the DataArray named `name` in a VTK XML text.
std::vector<double> data_array(const std::string& text, const std::string& name) {
  const std::regex pattern("Name=\"" + name + "\"[^>]*>([^<]*)<");
  std::smatch m;
  if (!std::regex_search(text, m, pattern)) return {};
  std::istringstream values(m[1].str());
  std::vector<double> out;
  for (double v; values >> v;) out.push_back(v);
  return out;
}

TEST(VtkSnapshots, ParticlesAndForceLinesCarryTheStateAndForces) {
  SceneDefinition s;
  s.domain = {true, 10.0};
  s.walls = {testing::fixed_wall("floor", {0.0, 0.0}, {0.0, 1.0})};
  s.disks = {testing::disk({0.4, 0.5}, 0.5, {0.25, -0.5}, 2.0), testing::disk({9.4, 0.5}, 0.45)};
  const World world = build_world(s);
  const double dt = 0.01;
  std::vector<Contact> contacts(3);
  contacts[0].key = {0, 1, -1};  // across x = 0
  contacts[0].normal = {1.0, 0.0};
  contacts[0].impulse_n = 0.02;
  contacts[0].impulse_t = 0.01;
  contacts[1].key = {0, 2, 0};  // disk 0 on the floor
  contacts[1].normal = {0.0, 1.0};
  contacts[1].impulse_n = 0.05;
  contacts[2].key = {1, 2, 0};  // a candidate carrying nothing: neither counted nor drawn
  contacts[2].normal = {0.0, 1.0};
  const testing::TempDir dir("vtk");
  write_particles_vtp(dir.path() / "p.vtp", world, contacts);
  write_contacts_vtp(dir.path() / "c.vtp", world, contacts, dt);
  write_pvd(dir.path() / "p.pvd", {{0.5, "p.vtp"}, {1.0, "q.vtp"}});

  const std::string p = testing::read_text(dir.path() / "p.vtp");
  EXPECT_NE(p.find("NumberOfPoints=\"2\" NumberOfVerts=\"2\""), std::string::npos);
  EXPECT_EQ(data_array(p, "Points"), (std::vector<double>{0.4, 0.5, 0, 9.4, 0.5, 0}));
  EXPECT_EQ(data_array(p, "radius"), (std::vector<double>{0.5, 0.45}));
  EXPECT_EQ(data_array(p, "velocity"), (std::vector<double>{0.25, -0.5, 0, 0, 0, 0}));
  EXPECT_EQ(data_array(p, "omega"), (std::vector<double>{2.0, 0.0}));
  EXPECT_EQ(data_array(p, "contact_count"), (std::vector<double>{2, 1}));

  const std::string c = testing::read_text(dir.path() / "c.vtp");
  EXPECT_NE(c.find("NumberOfPoints=\"4\" NumberOfVerts=\"0\" NumberOfLines=\"2\""),
            std::string::npos);
  // The line to disk 1 goes to its image at x = -0.6 (nearest through the boundary); the floor
  // contact ends at the contact point, r below the centre.
  const std::vector<double> points = data_array(c, "Points");
  ASSERT_EQ(points.size(), 12u);
  EXPECT_NEAR(points[3], -0.6, 1e-12);
  EXPECT_EQ(points[4], 0.5);
  EXPECT_EQ(points[9], 0.4);
  EXPECT_EQ(points[10], 0.0);
  const std::vector<double> normal = data_array(c, "normal_force");
  ASSERT_EQ(normal.size(), 2u);
  EXPECT_NEAR(normal[0], 2.0, 1e-12);
  EXPECT_NEAR(normal[1], 5.0, 1e-12);
  const std::vector<double> tangential = data_array(c, "tangential_force");
  EXPECT_NEAR(tangential[0], 1.0, 1e-12);
  EXPECT_EQ(tangential[1], 0.0);

  const std::string pvd = testing::read_text(dir.path() / "p.pvd");
  EXPECT_NE(pvd.find("<DataSet timestep=\"0.5\" file=\"p.vtp\"/>"), std::string::npos);
  EXPECT_NE(pvd.find("<DataSet timestep=\"1\" file=\"q.vtp\"/>"), std::string::npos);
}

}  // namespace
}  // namespace cdshear
