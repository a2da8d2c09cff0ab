// The TOML library's implementation, compiled here rather than linked from Debian's shared
// libtomlplusplus: that build prints a double through a stream with 17 significant digits
// (0.050000000000000003 in case.toml), since the library assumes GCC lacks std::to_chars for
// floating point. GCC 11 and later have it, so the implementation is built here with
// TOML_FLOAT_CHARCONV = 1: the shortest text that reads back as the same double (0.05), in every
// file cdshear writes with it. Every translation unit sees the same settings (CMakeLists.txt,
// cdshear_io's compile definitions).
#define TOML_IMPLEMENTATION
#include <toml++/toml.h>
