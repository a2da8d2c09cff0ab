// TOML text that cdshear writes (case.toml, scene.toml, campaign.toml, the `settings` listing):
// every float in its shortest form that reads back to the same double (0.05, not
// 0.050000000000000003). Written here because Debian's toml++ build prints doubles through a
// stream at 17 significant digits; strings, dates and keys that need quotes still go through
// toml++'s own formatter, so its escaping rules are the only ones.
#pragma once

#include <string>

#include <toml++/toml.h>

namespace cdshear {

/// A double as TOML reads it back exactly: the shortest round-trip form, with a decimal point or
/// an exponent so that it stays a float (`20.0`, `0.005`, `1e-5`, `inf`, `nan`).
std::string toml_float_text(double v);

/// A value as the right-hand side of `key = value` on one line (`0.5`, `"random"`, `[5.0, 10.0]`,
/// `{ 1 = "p.json" }`).
std::string toml_value_text(const toml::node& node);

/// A whole document: the table's own keys first, then each sub-table under its `[a.b]` header and
/// each array of tables as `[[a.b]]` entries, in the table's key order; tables marked inline stay
/// inline. Parsing the text gives back the same table (the same keys, types and values).
std::string toml_document_text(const toml::table& table);

}  // namespace cdshear
