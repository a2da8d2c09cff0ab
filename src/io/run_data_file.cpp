// HDF5 through its C API with a small RAII handle; the C++ bindings add little for a file of
// plain 1-4D arrays. Columns are described once (name + accessor) and serve writing and reading.
#include "run_data_file.hpp"

#include <fmt/format.h>
#include <hdf5.h>
#include <zlib.h>

#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <numbers>
#include <type_traits>

#include "build_info.hpp"
#include "config_error.hpp"
#include "outputs.hpp"
#include "toml_reader.hpp"

namespace cdshear {
namespace {

namespace fs = std::filesystem;

/// HDF5 closes what is still open when the process exits; a file whose close failed (a full disk)
/// stays open in the library, and closing it again at exit crashed (HDF5 1.10). Every identifier
/// here is closed by its owner, so the library is told to skip that clean-up; this runs before
/// any other HDF5 call, as it must.
[[maybe_unused]] const herr_t kNoCleanUpAtExit = H5dont_atexit();

/// Owns an HDF5 identifier and closes it with the matching function.
class Handle {
 public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  operator hid_t() const { return id_; }
  bool valid() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

/// Every HDF5 failure turns into an error naming the file and the object: ConfigError when
/// reading (bad input), WriteError when `writing` (exit 1: docs/reliability.md).
struct H5Context {
  std::string file;
  bool writing = false;
  [[noreturn]] void fail(const std::string& object, const std::string& problem) const {
    if (writing) throw WriteError(file, (object.empty() ? "" : object + ": ") + problem);
    throw ConfigError(file, object, problem);
  }
  void check(herr_t status, const std::string& object, const char* what) const {
    if (status < 0) fail(object, what);
  }
};

// --- the seal --------------------------------------------------------------------------------
// HDF5 1.10 itself can overflow a heap buffer on a damaged file (found by fuzz/fuzz_readers.cpp
// in 30 s: H5Aexists on a corrupted attribute message), and h5py uses the same library. So a
// run.h5 carries, in the first bytes of its 512-byte HDF5 user block, the line
//   cdshear-run crc32=XXXXXXXX size=N
// with the CRC-32 (zlib) and size of everything after the user block; cdshear and
// python/cdshear_analysis check it before opening the file with HDF5. One file, one atomic
// rename: the seal can never disagree with the content it was written for.

constexpr hsize_t kUserBlock = 512;
constexpr char kSealPrefix[] = "cdshear-run crc32=";

/// CRC-32 and size of the file's bytes after the user block.
std::pair<std::uint32_t, std::uint64_t> body_checksum(const H5Context& ctx, const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) ctx.fail("", "cannot read the file");
  in.seekg(static_cast<std::streamoff>(kUserBlock));
  uLong crc = crc32(0L, Z_NULL, 0);
  std::uint64_t size = 0;
  std::vector<char> buffer(1 << 16);
  while (in.read(buffer.data(), static_cast<std::streamsize>(buffer.size())) || in.gcount() > 0) {
    const auto got = static_cast<uInt>(in.gcount());
    crc = crc32(crc, reinterpret_cast<const Bytef*>(buffer.data()), got);
    size += got;
  }
  return {static_cast<std::uint32_t>(crc), size};
}

void seal(const H5Context& ctx, const fs::path& path) {
  const auto [crc, size] = body_checksum(ctx, path);
  char line[kUserBlock] = {};
  std::snprintf(line, sizeof line, "%s%08x size=%llu\n", kSealPrefix, crc,
                static_cast<unsigned long long>(size));
  std::fstream out(path, std::ios::binary | std::ios::in | std::ios::out);
  out.write(line, static_cast<std::streamsize>(std::strlen(line)));
  out.flush();
  if (!out) ctx.fail("", "cannot write the seal (disk full?)");
}

void check_seal(const H5Context& ctx, const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  char line[96] = {};
  in.read(line, sizeof line - 1);
  unsigned crc = 0;
  unsigned long long size = 0;
  // %llu would take "size=-5" as 2^64 - 5: the size must start with a digit.
  const char* size_text = std::strstr(line, " size=");
  if (std::strncmp(line, kSealPrefix, std::strlen(kSealPrefix)) != 0 ||
      std::sscanf(line + std::strlen(kSealPrefix), "%8x size=%llu", &crc, &size) != 2 ||
      size_text == nullptr || !std::isdigit(static_cast<unsigned char>(size_text[6])))
    ctx.fail("",
             "has no cdshear seal: not a run.h5 written by cdshear, or damaged (empty or "
             "truncated?)");
  const auto [actual_crc, actual_size] = body_checksum(ctx, path);
  if (actual_size != size || actual_crc != crc)
    ctx.fail("", "damaged: its content does not match the checksum it was written with (" +
                     std::to_string(actual_size) + " bytes of " + std::to_string(size) + ")");
}

// --- writing ---------------------------------------------------------------------------------

/// A creation property list of class `cls` (dataset or group) that stores no modification
/// times, so that one run, written twice, gives the same bytes.
Handle untimed_creation(hid_t cls) {
  const hid_t list = H5Pcreate(cls);
  if (list >= 0) H5Pset_obj_track_times(list, false);
  return Handle(list, H5Pclose);
}

void write_array(const H5Context& ctx, hid_t group, const std::string& name, hid_t mem_type,
                 const void* data, std::size_t size, const std::vector<hsize_t>& dims) {
  std::size_t count = 1;
  for (hsize_t d : dims) count *= d;
  if (count != size)  // a programming error; never let HDF5 read past the buffer
    ctx.fail(name,
             "has " + std::to_string(size) + " values for " + std::to_string(count) + " places");
  Handle space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose);
  const Handle create_list = untimed_creation(H5P_DATASET_CREATE);
  Handle set(H5Dcreate2(group, name.c_str(),
                        mem_type == H5T_NATIVE_DOUBLE ? H5T_IEEE_F64LE : H5T_STD_I64LE, space,
                        H5P_DEFAULT, create_list, H5P_DEFAULT),
             H5Dclose);
  if (!set.valid()) ctx.fail(name, "cannot create dataset");
  bool empty = false;
  for (hsize_t d : dims) empty = empty || d == 0;
  if (!empty)
    ctx.check(H5Dwrite(set, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), name,
              "cannot write dataset");
}
void write_doubles(const H5Context& ctx, hid_t group, const std::string& name,
                   const std::vector<double>& v, std::vector<hsize_t> dims = {}) {
  if (dims.empty()) dims = {v.size()};
  write_array(ctx, group, name, H5T_NATIVE_DOUBLE, v.data(), v.size(), dims);
}
void write_integers(const H5Context& ctx, hid_t group, const std::string& name,
                    const std::vector<std::int64_t>& v) {
  write_array(ctx, group, name, H5T_NATIVE_INT64, v.data(), v.size(), {v.size()});
}

void attr_double(const H5Context& ctx, hid_t obj, const char* name, const std::vector<double>& v) {
  const hsize_t dim = v.size();
  Handle space(H5Screate_simple(1, &dim, nullptr), H5Sclose);
  Handle a(H5Acreate2(obj, name, H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  ctx.check(H5Awrite(a, H5T_NATIVE_DOUBLE, v.data()), name, "cannot write attribute");
}
void attr_double(const H5Context& ctx, hid_t obj, const char* name, double v) {
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle a(H5Acreate2(obj, name, H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  ctx.check(H5Awrite(a, H5T_NATIVE_DOUBLE, &v), name, "cannot write attribute");
}
void attr_int(const H5Context& ctx, hid_t obj, const char* name, std::int64_t v) {
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle a(H5Acreate2(obj, name, H5T_STD_I64LE, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  ctx.check(H5Awrite(a, H5T_NATIVE_INT64, &v), name, "cannot write attribute");
}
void attr_string(const H5Context& ctx, hid_t obj, const char* name, const std::string& v) {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type, std::max<std::size_t>(1, v.size()));
  H5Tset_cset(type, H5T_CSET_UTF8);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle a(H5Acreate2(obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  const std::string padded = v.empty() ? std::string(1, '\0') : v;
  ctx.check(H5Awrite(a, type, padded.data()), name, "cannot write attribute");
}

// --- reading ---------------------------------------------------------------------------------

std::vector<hsize_t> dataset_dims(const H5Context& ctx, hid_t set, const std::string& name) {
  Handle space(H5Dget_space(set), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space);
  if (rank < 0) ctx.fail(name, "unreadable dataset");
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  return dims;
}

template <typename T>
std::vector<T> read_array(const H5Context& ctx, hid_t group, const std::string& name,
                          hid_t mem_type, std::size_t expected = std::size_t(-1)) {
  if (H5Lexists(group, name.c_str(), H5P_DEFAULT) <= 0) ctx.fail(name, "dataset missing");
  Handle set(H5Dopen2(group, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!set.valid()) ctx.fail(name, "cannot open dataset");
  std::size_t count = 1;
  for (hsize_t d : dataset_dims(ctx, set, name)) count *= d;
  if (expected != std::size_t(-1) && count != expected)
    ctx.fail(name,
             "has " + std::to_string(count) + " values, expected " + std::to_string(expected));
  std::vector<T> v(count);
  if (count > 0)
    ctx.check(H5Dread(set, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), name,
              "cannot read dataset (truncated file?)");
  return v;
}
std::vector<double> read_doubles(const H5Context& ctx, hid_t group, const std::string& name,
                                 std::size_t expected = std::size_t(-1)) {
  return read_array<double>(ctx, group, name, H5T_NATIVE_DOUBLE, expected);
}

std::vector<double> read_attr_doubles(const H5Context& ctx, hid_t obj, const char* name) {
  if (H5Aexists(obj, name) <= 0) ctx.fail(name, "attribute missing");
  Handle a(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  Handle space(H5Aget_space(a), H5Sclose);
  const hssize_t count = H5Sget_simple_extent_npoints(space);
  std::vector<double> v(static_cast<std::size_t>(std::max<hssize_t>(0, count)));
  ctx.check(H5Aread(a, H5T_NATIVE_DOUBLE, v.data()), name, "cannot read attribute");
  return v;
}
double read_attr_double(const H5Context& ctx, hid_t obj, const char* name) {
  const std::vector<double> v = read_attr_doubles(ctx, obj, name);
  if (v.size() != 1) ctx.fail(name, "expected one number");
  return v[0];
}
std::string read_attr_string(const H5Context& ctx, hid_t obj, const char* name) {
  if (H5Aexists(obj, name) <= 0) ctx.fail(name, "attribute missing");
  Handle a(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(a), H5Tclose);
  if (H5Tget_class(type) != H5T_STRING || H5Tis_variable_str(type) > 0)
    ctx.fail(name, "not a fixed-length string");
  std::string s(H5Tget_size(type), '\0');
  ctx.check(H5Aread(a, type, s.data()), name, "cannot read attribute");
  if (const auto end = s.find('\0'); end != std::string::npos) s.resize(end);
  return s;
}

// --- the columns of the file -----------------------------------------------------------------

struct SeriesColumn {
  const char* name;
  bool integer;
  std::function<double(const SeriesRow&)> get;
  std::function<void(SeriesRow&, double)> set;
};

const std::vector<SeriesColumn>& series_columns() {
  static const std::vector<SeriesColumn> columns = {
      {"step", true, [](const SeriesRow& r) { return static_cast<double>(r.step); },
       [](SeriesRow& r, double v) { r.step = static_cast<std::uint64_t>(v); }},
      {"time", false, [](const SeriesRow& r) { return r.time; },
       [](SeriesRow& r, double v) { r.time = v; }},
      {"com_vx", false, [](const SeriesRow& r) { return r.com_vx; },
       [](SeriesRow& r, double v) { r.com_vx = v; }},
      {"block_vx", false, [](const SeriesRow& r) { return r.block_vx; },
       [](SeriesRow& r, double v) { r.block_vx = v; }},
      {"height", false, [](const SeriesRow& r) { return r.height; },
       [](SeriesRow& r, double v) { r.height = v; }},
      {"solid_fraction", false, [](const SeriesRow& r) { return r.solid_fraction; },
       [](SeriesRow& r, double v) { r.solid_fraction = v; }},
      {"kinetic_energy", false, [](const SeriesRow& r) { return r.kinetic_energy; },
       [](SeriesRow& r, double v) { r.kinetic_energy = v; }},
      {"contacts", true, [](const SeriesRow& r) { return static_cast<double>(r.contacts); },
       [](SeriesRow& r, double v) { r.contacts = static_cast<std::uint64_t>(v); }},
      {"force_carrying", true,
       [](const SeriesRow& r) { return static_cast<double>(r.force_carrying); },
       [](SeriesRow& r, double v) { r.force_carrying = static_cast<std::uint64_t>(v); }},
      {"closed", true, [](const SeriesRow& r) { return static_cast<double>(r.closed); },
       [](SeriesRow& r, double v) { r.closed = static_cast<std::uint64_t>(v); }},
      {"bottom_fx", false, [](const SeriesRow& r) { return r.bottom_force.x; },
       [](SeriesRow& r, double v) { r.bottom_force.x = v; }},
      {"bottom_fy", false, [](const SeriesRow& r) { return r.bottom_force.y; },
       [](SeriesRow& r, double v) { r.bottom_force.y = v; }},
      {"top_fx", false, [](const SeriesRow& r) { return r.top_force.x; },
       [](SeriesRow& r, double v) { r.top_force.x = v; }},
      {"top_fy", false, [](const SeriesRow& r) { return r.top_force.y; },
       [](SeriesRow& r, double v) { r.top_force.y = v; }},
      {"bottom_mu", false, [](const SeriesRow& r) { return r.bottom_mu; },
       [](SeriesRow& r, double v) { r.bottom_mu = v; }},
      {"top_mu", false, [](const SeriesRow& r) { return r.top_mu; },
       [](SeriesRow& r, double v) { r.top_mu = v; }},
      // Read back as one step with that many sweeps, which writes the same mean again.
      {"sweeps_mean", false, [](const SeriesRow& r) { return r.solver.sweeps_mean(); },
       [](SeriesRow& r, double v) {
         r.solver.steps = 1;
         r.solver.sweeps_sum = v;
       }},
      {"sweeps_max", true, [](const SeriesRow& r) { return double(r.solver.sweeps_max); },
       [](SeriesRow& r, double v) { r.solver.sweeps_max = static_cast<int>(v); }},
      {"capped_steps", true, [](const SeriesRow& r) { return double(r.solver.capped_steps); },
       [](SeriesRow& r, double v) { r.solver.capped_steps = static_cast<std::uint64_t>(v); }},
      {"residual_max", false, [](const SeriesRow& r) { return r.solver.residual_max; },
       [](SeriesRow& r, double v) { r.solver.residual_max = v; }},
      {"overlap_max", false, [](const SeriesRow& r) { return r.solver.overlap_max; },
       [](SeriesRow& r, double v) { r.solver.overlap_max = v; }},
  };
  return columns;
}

using WindowScalar = std::pair<const char*, double WindowProfile::*>;
const WindowScalar kWindowScalars[] = {
    {"t_start", &WindowProfile::t_start},  {"t_end", &WindowProfile::t_end},
    {"height", &WindowProfile::height},    {"com_vx", &WindowProfile::com_vx},
    {"wall_mu", &WindowProfile::wall_mu},  {"slip_bottom", &WindowProfile::slip_bottom},
    {"slip_top", &WindowProfile::slip_top}};
using WindowCount = std::pair<const char*, std::uint64_t WindowProfile::*>;
const WindowCount kWindowCounts[] = {{"samples", &WindowProfile::samples},
                                     {"slip_bottom_count", &WindowProfile::slip_bottom_count},
                                     {"slip_top_count", &WindowProfile::slip_top_count}};
using WindowForce = std::pair<const char*, Vec2 WindowProfile::*>;
const WindowForce kWindowForces[] = {{"bottom_force", &WindowProfile::bottom_force},
                                     {"top_force", &WindowProfile::top_force}};
using WindowProfileField = std::pair<const char*, std::vector<double> WindowProfile::*>;
const WindowProfileField kWindowProfiles[] = {
    {"solid_fraction", &WindowProfile::solid_fraction},
    {"vx", &WindowProfile::vx},
    {"mu_eff", &WindowProfile::mu_eff},
    {"coordination", &WindowProfile::coordination},
    {"force_carrying_coordination", &WindowProfile::force_carrying_coordination},
    {"shear_rate", &WindowProfile::shear_rate},
    {"inertial_number", &WindowProfile::inertial_number}};
using WindowTensor = std::pair<const char*, std::vector<Tensor2> WindowProfile::*>;
using TopStripeField = std::pair<const char*, std::vector<double> TopStripes::*>;
const TopStripeField kTopStripeProfiles[] = {
    {"solid_fraction", &TopStripes::solid_fraction},
    {"vx", &TopStripes::vx},
    {"coordination", &TopStripes::coordination},
    {"force_carrying_coordination", &TopStripes::force_carrying_coordination}};
const WindowTensor kWindowTensors[] = {{"contact_stress", &WindowProfile::contact_stress},
                                       {"kinetic_stress", &WindowProfile::kinetic_stress},
                                       {"rotational_stress", &WindowProfile::rotational_stress},
                                       {"stress", &WindowProfile::stress}};
using RegionField = std::pair<const char*, double RegionValues::*>;
const RegionField kRegionFields[] = {
    {"bulk_mu_eff", &RegionValues::bulk_mu_eff},
    {"bulk_solid_fraction", &RegionValues::bulk_solid_fraction},
    {"bulk_coordination", &RegionValues::bulk_coordination},
    {"bulk_force_carrying_coordination", &RegionValues::bulk_force_carrying_coordination},
    {"bulk_shear_rate", &RegionValues::bulk_shear_rate},
    {"bulk_inertial_number", &RegionValues::bulk_inertial_number},
    {"bottom_mu_eff", &RegionValues::bottom_mu_eff},
    {"bottom_solid_fraction", &RegionValues::bottom_solid_fraction},
    {"bottom_coordination", &RegionValues::bottom_coordination},
    {"bottom_force_carrying_coordination", &RegionValues::bottom_force_carrying_coordination},
    {"bottom_velocity_jump", &RegionValues::bottom_velocity_jump},
    {"bottom_inertial_number", &RegionValues::bottom_inertial_number},
    {"top_mu_eff", &RegionValues::top_mu_eff},
    {"top_solid_fraction", &RegionValues::top_solid_fraction},
    {"top_coordination", &RegionValues::top_coordination},
    {"top_force_carrying_coordination", &RegionValues::top_force_carrying_coordination},
    {"top_velocity_jump", &RegionValues::top_velocity_jump},
    {"top_inertial_number", &RegionValues::top_inertial_number}};

/// Group name of a boundary thickness: h10, h5, h7.5 (shortest exact decimal).
std::string region_group_name(double h) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "h%.15g", h);
  return buffer;
}

Handle create_group(const H5Context& ctx, hid_t parent, const std::string& name) {
  const Handle create_list = untimed_creation(H5P_GROUP_CREATE);
  const hid_t id = H5Gcreate2(parent, name.c_str(), H5P_DEFAULT, create_list, H5P_DEFAULT);
  if (id < 0) ctx.fail(name, "cannot create group");
  return Handle(id, H5Gclose);
}
Handle open_group(const H5Context& ctx, hid_t parent, const std::string& name) {
  if (H5Lexists(parent, name.c_str(), H5P_DEFAULT) <= 0) ctx.fail(name, "group missing");
  const hid_t id = H5Gopen2(parent, name.c_str(), H5P_DEFAULT);
  if (id < 0) ctx.fail(name, "cannot open group");
  return Handle(id, H5Gclose);
}

void write_snapshot(const H5Context& ctx, hid_t file, const World& world,
                    const std::vector<Contact>& contacts, double dt, double relative_threshold) {
  Handle g = create_group(ctx, file, "snapshot");
  const Disks& d = world.disks;
  const std::size_t n = d.size();
  const double bottom = world.walls[0].point.y;
  std::vector<double> x(n), y(n), vx(n), vy(n);
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = d.position[i].x;
    y[i] = d.position[i].y - bottom;
    vx[i] = d.velocity[i].x;
    vy[i] = d.velocity[i].y;
  }
  write_doubles(ctx, g, "x", x);
  write_doubles(ctx, g, "y", y);
  write_doubles(ctx, g, "radius", d.radius);
  write_doubles(ctx, g, "vx", vx);
  write_doubles(ctx, g, "vy", vy);
  write_doubles(ctx, g, "omega", d.omega);
  const double threshold = force_carrying_threshold(contacts, relative_threshold);
  std::vector<std::int64_t> a_index, b_index;
  std::vector<double> ax, ay, bx, by, force;
  for (const Contact& c : contacts) {
    if (!(c.impulse_n > threshold)) continue;
    const auto a = static_cast<std::size_t>(c.key.body_a);
    const auto b = static_cast<std::size_t>(c.key.body_b);
    const Vec2 pa{d.position[a].x, d.position[a].y - bottom};
    // The partner as seen from a: b's nearest periodic image, or the contact point on a wall,
    // -r_a along the wall's normal (detection's lever_a n, taken from the state: a checkpoint
    // keeps the contacts' impulses, not their geometry, and a resume that ends at once writes
    // this snapshot from it).
    const Vec2 pb = b < n ? pa + world.domain.minimum_image(d.position[b] - d.position[a])
                          : pa + (-d.radius[a]) * world.walls[b - n].normal;
    a_index.push_back(static_cast<std::int64_t>(a));
    b_index.push_back(static_cast<std::int64_t>(b));
    ax.push_back(pa.x);
    ay.push_back(pa.y);
    bx.push_back(pb.x);
    by.push_back(pb.y);
    force.push_back(c.impulse_n / dt);
  }
  write_integers(ctx, g, "contact_a", a_index);
  write_integers(ctx, g, "contact_b", b_index);
  write_doubles(ctx, g, "contact_ax", ax);
  write_doubles(ctx, g, "contact_ay", ay);
  write_doubles(ctx, g, "contact_bx", bx);
  write_doubles(ctx, g, "contact_by", by);
  write_doubles(ctx, g, "contact_normal_force", force);
  attr_double(ctx, g, "time", world.time);
  attr_double(ctx, g, "length_x", world.domain.length_x);
  attr_double(ctx, g, "height", world.walls[1].point.y - bottom);
}

/// One W x S (x 2 x 2 for tensors) dataset of the windows: the profile `get` picks from each
/// window, S entries each.
template <class Get>
void write_window_profiles(const H5Context& ctx, hid_t group, const char* name,
                           const std::vector<WindowProfile>& ws, hsize_t stripes, Get get) {
  using Profile = std::decay_t<decltype(get(ws.front()))>;
  constexpr bool tensors = std::is_same_v<Profile, std::vector<Tensor2>>;
  std::vector<double> v;
  for (const WindowProfile& w : ws) {
    const Profile& profile = get(w);
    if constexpr (tensors) {
      for (const Tensor2& t : profile) v.insert(v.end(), {t.xx, t.xy, t.yx, t.yy});
    } else {
      v.insert(v.end(), profile.begin(), profile.end());
    }
  }
  if constexpr (tensors)
    write_doubles(ctx, group, name, v, {ws.size(), stripes, 2, 2});
  else
    write_doubles(ctx, group, name, v, {ws.size(), stripes});
}

}  // namespace

/// Everything of run.h5 into the open `file`.
void write_run_file(const H5Context& ctx, hid_t file, const RunMetadata& meta,
                    const ShearMeasurement& m, const World& world,
                    const std::vector<Contact>& contacts) {
  const MeasureOptions& o = m.options();
  attr_string(ctx, file, "format", "cdshear-run");
  attr_int(ctx, file, "format_version", kRunDataFormatVersion);
  attr_string(ctx, file, "program_version", CDSHEAR_VERSION);
  attr_string(ctx, file, "program_build", build_description());
  attr_string(ctx, file, "case_toml", meta.case_toml);
  attr_int(ctx, file, "n", static_cast<std::int64_t>(meta.n));
  attr_double(ctx, file, "length_x", meta.length_x);
  attr_double(ctx, file, "height", meta.height);
  attr_double(ctx, file, "velocity", meta.velocity);
  attr_double(ctx, file, "normal_stress", meta.normal_stress);
  attr_double(ctx, file, "dt", meta.dt);
  attr_int(ctx, file, "seed", static_cast<std::int64_t>(meta.seed));
  attr_int(ctx, file, "solver_seed", static_cast<std::int64_t>(meta.solver_seed));
  attr_double(ctx, file, "duration", meta.duration);
  attr_double(ctx, file, "sample_interval", o.sample_interval);
  attr_double(ctx, file, "window", o.window);
  // The intervals actually used: whole numbers of steps and of samples.
  attr_int(ctx, file, "sample_steps", static_cast<std::int64_t>(m.sample_every()));
  attr_int(ctx, file, "window_samples", static_cast<std::int64_t>(m.samples_per_window()));
  attr_double(ctx, file, "stripe_thickness", o.stripe_thickness);
  attr_double(ctx, file, "stripe_span", o.stripe_span);
  attr_double(ctx, file, "boundary_thickness", o.boundary_thickness);
  attr_double(ctx, file, "force_threshold", o.force_threshold);
  attr_double(ctx, file, "contact_gap", o.contact_gap);
  attr_double(ctx, file, "inertial_mass", kInertialMass);
  attr_double(ctx, file, "time", meta.time);
  attr_int(ctx, file, "step", static_cast<std::int64_t>(meta.step));
  attr_int(ctx, file, "finished", meta.finished ? 1 : 0);

  {
    Handle g = create_group(ctx, file, "series");
    const std::vector<SeriesRow>& rows = m.series();
    for (const SeriesColumn& col : series_columns()) {
      if (col.integer) {
        std::vector<std::int64_t> v;
        for (const SeriesRow& r : rows) v.push_back(static_cast<std::int64_t>(col.get(r)));
        write_integers(ctx, g, col.name, v);
      } else {
        std::vector<double> v;
        for (const SeriesRow& r : rows) v.push_back(col.get(r));
        write_doubles(ctx, g, col.name, v);
      }
    }
  }

  Handle g = create_group(ctx, file, "windows");
  const std::vector<WindowProfile>& ws = m.windows();
  const hsize_t w_count = ws.size(), s_count = m.stripes();
  write_doubles(ctx, g, "y", m.stripe_centres());
  for (const auto& [name, field] : kWindowScalars) {
    std::vector<double> v;
    for (const WindowProfile& w : ws) v.push_back(w.*field);
    write_doubles(ctx, g, name, v);
  }
  for (const auto& [name, field] : kWindowCounts) {
    std::vector<std::int64_t> v;
    for (const WindowProfile& w : ws) v.push_back(static_cast<std::int64_t>(w.*field));
    write_integers(ctx, g, name, v);
  }
  for (const auto& [name, field] : kWindowForces) {
    std::vector<double> v;
    for (const WindowProfile& w : ws) v.insert(v.end(), {(w.*field).x, (w.*field).y});
    write_doubles(ctx, g, name, v, {w_count, 2});
  }
  for (const auto& [name, field] : kWindowProfiles)
    write_window_profiles(
        ctx, g, name, ws, s_count, [f = field](const WindowProfile& w) -> auto& { return w.*f; });
  for (const auto& [name, field] : kWindowTensors)
    write_window_profiles(
        ctx, g, name, ws, s_count, [f = field](const WindowProfile& w) -> auto& { return w.*f; });
  {
    Handle t = create_group(ctx, g, "top_stripes");
    const hsize_t t_count = m.top_stripe_depths().size();
    write_doubles(ctx, t, "depth", m.top_stripe_depths());
    for (const auto& [name, field] : kTopStripeProfiles)
      write_window_profiles(
          ctx, t, name, ws,
          t_count, [f = field](const WindowProfile& w) -> auto& { return w.top_stripes.*f; });
    write_window_profiles(
        ctx, t, "stress", ws, t_count,
        [](const WindowProfile& w) -> auto& { return w.top_stripes.stress; });
  }
  Handle regions = create_group(ctx, g, "regions");
  for (std::size_t k = 0; k < o.boundary_thickness.size(); ++k) {
    const std::string group_name = region_group_name(o.boundary_thickness[k]);
    Handle r = create_group(ctx, regions, group_name);
    attr_double(ctx, r, "h", o.boundary_thickness[k]);
    for (const auto& [name, field] : kRegionFields) {
      std::vector<double> v;
      for (const WindowProfile& w : ws) v.push_back(w.regions.at(k).*field);
      write_doubles(ctx, r, name, v);
    }
  }
  write_snapshot(ctx, file, world, contacts, meta.dt, o.force_threshold);
}

void write_run_data(const fs::path& path, const RunMetadata& meta, const ShearMeasurement& m,
                    const World& world, const std::vector<Contact>& contacts) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors are reported as ConfigError
  const fs::path tmp = temporary_path(path);
  const H5Context ctx{tmp.string(), /*writing=*/true};
  try {
    // The first kUserBlock bytes are HDF5's user block: it holds the seal (CRC-32 of the rest).
    Handle create_list(H5Pcreate(H5P_FILE_CREATE), H5Pclose);
    H5Pset_userblock(create_list, kUserBlock);
    const hid_t file = H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, create_list, H5P_DEFAULT);
    if (file < 0) ctx.fail("", "cannot create the file");
    try {
      write_run_file(ctx, file, meta, m, world, contacts);
    } catch (...) {
      H5Fclose(file);
      throw;
    }
    if (H5Fclose(file) < 0) ctx.fail("", "cannot close the file (disk full?)");
    seal(ctx, tmp);
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);  // never leave a half-written temporary behind
    throw;
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec)
    throw WriteError(path.string(), "cannot rename the new data file " + tmp.string() +
                                        " into place: " + ec.message() +
                                        " (that file holds the newest data)");
}

namespace {

/// What cdshear run cannot write is refused here as by the analysis's reader
/// (python/cdshear_analysis/rundata.py, _check_physics): whole n >= 1, finite positive sizes,
/// speeds, stresses, durations and intervals, a time reached >= 0.
void check_run_attributes(const H5Context& ctx, hid_t file) {
  for (const char* key : {"n", "length_x", "height", "velocity", "normal_stress", "dt", "duration",
                          "window", "sample_interval", "stripe_thickness"})
    if (const double v = read_attr_double(ctx, file, key); !(v > 0.0) || !std::isfinite(v))
      ctx.fail(key, "is " + format_number(v) + ": it must be a finite number > 0");
  if (const double n = read_attr_double(ctx, file, "n"); n != std::floor(n))
    ctx.fail("n", "is " + format_number(n) + ": a number of disks is whole");
  if (const double t = read_attr_double(ctx, file, "time"); !(t >= 0.0) || !std::isfinite(t))
    ctx.fail("time", "is " + format_number(t) + ": it must be a finite number >= 0");
}

/// The series' time is finite and increases from row to row.
void check_series_time(const H5Context& ctx, const std::vector<double>& time) {
  for (std::size_t r = 0; r < time.size(); ++r) {
    if (!std::isfinite(time[r]))
      ctx.fail("series/time", fmt::format("is {} at row {}: not finite", time[r], r));
    if (r > 0 && !(time[r] > time[r - 1]))
      ctx.fail("series/time",
               fmt::format("does not increase at row {} ({} then {})", r, time[r - 1], time[r]));
  }
}

/// The windows' profiles of one W x S (x 2 x 2 for tensors) dataset into the vector `get` picks
/// from each window.
template <class Get>
void read_window_profiles(const H5Context& ctx, hid_t group, const char* name,
                          std::vector<WindowProfile>& ws, std::size_t stripes, Get get) {
  using Profile = std::decay_t<decltype(get(ws.front()))>;
  constexpr std::size_t per_stripe = std::is_same_v<Profile, std::vector<Tensor2>> ? 4 : 1;
  const std::vector<double> v = read_doubles(ctx, group, name, per_stripe * ws.size() * stripes);
  for (std::size_t w = 0; w < ws.size(); ++w) {
    Profile& profile = get(ws[w]);
    const double* x = v.data() + per_stripe * w * stripes;
    if constexpr (per_stripe == 4) {
      for (std::size_t s = 0; s < stripes; ++s, x += 4) profile.push_back({x[0], x[1], x[2], x[3]});
    } else {
      profile.assign(x, x + stripes);
    }
  }
}

/// The windows' profiles of a run.h5 (group "windows", its regions included) into `data`,
/// whose options (boundary_thickness) are read already.
void read_windows(const H5Context& ctx, hid_t file, RunData& data) {
  const MeasureOptions& o = data.options;
  Handle g = open_group(ctx, file, "windows");
  data.stripe_centres = read_doubles(ctx, g, "y");
  if (data.stripe_centres.empty()) ctx.fail("windows/y", "is empty: the profiles have no stripes");
  const std::size_t w_count = read_doubles(ctx, g, "t_start").size();
  const std::size_t s_count = data.stripe_centres.size();
  data.windows.resize(w_count);
  for (const auto& [name, field] : kWindowScalars) {
    const std::vector<double> v = read_doubles(ctx, g, name, w_count);
    for (std::size_t w = 0; w < w_count; ++w) data.windows[w].*field = v[w];
  }
  for (const auto& [name, field] : kWindowCounts) {
    const std::vector<double> v = read_doubles(ctx, g, name, w_count);
    for (std::size_t w = 0; w < w_count; ++w)
      data.windows[w].*field = static_cast<std::uint64_t>(v[w]);
  }
  for (const auto& [name, field] : kWindowForces) {
    const std::vector<double> v = read_doubles(ctx, g, name, 2 * w_count);
    for (std::size_t w = 0; w < w_count; ++w) data.windows[w].*field = {v[2 * w], v[2 * w + 1]};
  }
  std::vector<WindowProfile>& ws = data.windows;
  for (const auto& [name, field] : kWindowProfiles)
    read_window_profiles(
        ctx, g, name, ws, s_count, [f = field](WindowProfile & w) -> auto& { return w.*f; });
  for (const auto& [name, field] : kWindowTensors)
    read_window_profiles(
        ctx, g, name, ws, s_count, [f = field](WindowProfile & w) -> auto& { return w.*f; });
  {
    Handle t = open_group(ctx, g, "top_stripes");
    data.top_stripe_depths = read_doubles(ctx, t, "depth");
    const std::size_t t_count = data.top_stripe_depths.size();
    for (const auto& [name, field] : kTopStripeProfiles)
      read_window_profiles(
          ctx, t, name, ws,
          t_count, [f = field](WindowProfile & w) -> auto& { return w.top_stripes.*f; });
    read_window_profiles(
        ctx, t, "stress", ws, t_count,
        [](WindowProfile & w) -> auto& { return w.top_stripes.stress; });
  }
  Handle regions = open_group(ctx, g, "regions");
  for (const double h : o.boundary_thickness) {
    Handle r = open_group(ctx, regions, region_group_name(h));
    std::vector<RegionValues> values(w_count);
    for (RegionValues& v : values) v.h = h;
    for (const auto& [name, field] : kRegionFields) {
      const std::vector<double> v = read_doubles(ctx, r, name, w_count);
      for (std::size_t w = 0; w < w_count; ++w) values[w].*field = v[w];
    }
    for (std::size_t w = 0; w < w_count; ++w) data.windows[w].regions.push_back(values[w]);
  }
}

}  // namespace

RunData read_run_data(const fs::path& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const H5Context ctx{path.string()};
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (!fs::exists(status)) ctx.fail("", "no such file (not a cdshear run folder?)");
  if (!fs::is_regular_file(status))
    ctx.fail("", "is not a regular file (a folder, a FIFO or a device): not a run's data");
  check_seal(ctx, path);  // before HDF5 sees a byte: it can crash on a damaged file
  if (H5Fis_hdf5(path.c_str()) <= 0) ctx.fail("", "not an HDF5 file (empty or truncated?)");
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.valid()) ctx.fail("", "cannot open as HDF5 (truncated?)");
  if (read_attr_string(ctx, file, "format") != "cdshear-run")
    ctx.fail("format", "not a cdshear run data file");
  if (const double version = read_attr_double(ctx, file, "format_version");
      version != kRunDataFormatVersion)
    ctx.fail("format_version",
             fmt::format("format version {} where this cdshear reads {}: {}", version,
                         kRunDataFormatVersion,
                         version < kRunDataFormatVersion
                             ? "written with earlier measurement definitions (Z, the stress, "
                               "the top layer); "
                               "`cdshear analyze` still reads it, but a run cannot be resumed "
                               "across the change (start a new run)"
                             : "written by a newer cdshear"));
  RunData data;
  RunMetadata& meta = data.meta;
  meta.case_toml = read_attr_string(ctx, file, "case_toml");
  check_run_attributes(ctx, file);
  meta.n = static_cast<std::size_t>(read_attr_double(ctx, file, "n"));
  meta.length_x = read_attr_double(ctx, file, "length_x");
  meta.height = read_attr_double(ctx, file, "height");
  meta.velocity = read_attr_double(ctx, file, "velocity");
  meta.normal_stress = read_attr_double(ctx, file, "normal_stress");
  meta.dt = read_attr_double(ctx, file, "dt");
  meta.seed = static_cast<std::uint64_t>(read_attr_double(ctx, file, "seed"));
  meta.solver_seed = static_cast<std::uint64_t>(read_attr_double(ctx, file, "solver_seed"));
  meta.duration = read_attr_double(ctx, file, "duration");
  meta.time = read_attr_double(ctx, file, "time");
  meta.step = static_cast<std::uint64_t>(read_attr_double(ctx, file, "step"));
  meta.finished = read_attr_double(ctx, file, "finished") != 0.0;
  MeasureOptions& o = data.options;
  o.sample_interval = read_attr_double(ctx, file, "sample_interval");
  o.window = read_attr_double(ctx, file, "window");
  o.stripe_thickness = read_attr_double(ctx, file, "stripe_thickness");
  o.stripe_span = read_attr_double(ctx, file, "stripe_span");
  o.boundary_thickness = read_attr_doubles(ctx, file, "boundary_thickness");
  o.force_threshold = read_attr_double(ctx, file, "force_threshold");
  o.contact_gap = read_attr_double(ctx, file, "contact_gap");

  {
    Handle g = open_group(ctx, file, "series");
    const std::vector<double> time = read_doubles(ctx, g, "time");
    check_series_time(ctx, time);
    const std::size_t rows = time.size();
    data.series.resize(rows);
    for (const SeriesColumn& col : series_columns()) {
      const std::vector<double> v = read_doubles(ctx, g, col.name, rows);
      for (std::size_t r = 0; r < rows; ++r) col.set(data.series[r], v[r]);
    }
  }
  read_windows(ctx, file, data);
  return data;
}

}  // namespace cdshear
