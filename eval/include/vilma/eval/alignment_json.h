// Reading the alignment of an earlier `vilma eval --json` run (`vilma eval --align-from`,
// `vilma localize --align-from`) with a strict JSON reader of its own (RFC 8259: the files
// vilma writes; the tree has no JSON library).
#pragma once

#include <string>

#include "vilma/core/trajectory_eval.h"

namespace vilma::console {

// The alignment_transform (S_G_E: scale, translation_m, quaternion_wxyz) of a `vilma eval
// --json` file (schema_version 1), as an Alignment of type kFixed. Strict JSON (RFC 8259, no
// duplicate keys); throws InputError naming the file, the field and the expectation (missing,
// wrong type, wrong length, scale <= 0, quaternion norm off 1 by more than 1e-6). The
// quaternion is normalized.
Alignment ParseAlignmentJson(const std::string& text, const std::string& path);
Alignment ReadAlignmentJson(const std::string& path);


}  // namespace vilma::console
