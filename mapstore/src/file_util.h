// Private file helpers of the map store.
#pragma once

#include <string>

namespace vilma {
namespace mapstore {

// Reads a whole file; false if it cannot be opened.
bool ReadWholeFile(const std::string& path, std::string* content);

}  // namespace mapstore
}  // namespace vilma
