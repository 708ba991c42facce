// JSON text helpers shared by the writers of JSON (vilma eval --json, the HTML map viewer).
#pragma once

#include <string>

namespace vilma {

// A JSON string literal (quotes included) with the escapes RFC 8259 requires: '"', '\\',
// control characters (\n, \t, \r by name, the others as \u00XX); other bytes (UTF-8) as they
// are. With `for_html_script`, '<', '>' and '&' are \u escapes too, so that the literal can sit
// inside an HTML <script> element ("</script>" cannot end it).
std::string JsonString(const std::string& text, bool for_html_script = false);

// A JSON number with 10 significant digits; non-finite values (never valid JSON) become null,
// -0 becomes 0.
std::string JsonNumber(double v);

}  // namespace vilma
