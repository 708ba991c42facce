// Reading the alignment of an earlier `vilma eval --json` run (`vilma eval --align-from`,
// `vilma localize --align-from`): strict JSON (RFC 8259) through nlohmann-json's SAX parser,
// with duplicate keys and numbers out of a double's range rejected too (nlohmann accepts the
// first and throws a position-less exception for the second).
#pragma once

#include <string>

#include "vilma/eval/alignment.h"

namespace vilma {

// The alignment_transform (S_G_E: scale, translation_m, quaternion_wxyz) of a `vilma eval
// --json` file (schema_version 1), as an Alignment of type kFixed. Other keys are ignored.
// Throws InputError naming the file and, for a syntax error, the line and column with
// nlohmann-json's description ("FILE: expected valid JSON: syntax error while parsing object
// key - unexpected '}'; expected string literal at line 1, column 22"), else the field and the
// expectation (missing, wrong type, wrong length, scale <= 0, quaternion norm off 1 by more
// than 1e-6). The quaternion is normalized.
Alignment ParseAlignmentJson(const std::string& text, const std::string& path);
// Reads `path` (InputError if it cannot be read) and calls the above.
Alignment ReadAlignmentJson(const std::string& path);

}  // namespace vilma
