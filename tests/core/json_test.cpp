// JsonString: RFC 8259 escapes, and the HTML-script variant.
#include <catch2/catch.hpp>

#include "vilma/core/json.h"

namespace vilma {
namespace {

TEST_CASE("JsonString escapes what JSON requires and keeps UTF-8") {
  CHECK(JsonString("plain") == "\"plain\"");
  CHECK(JsonString("a\"b\\c") == "\"a\\\"b\\\\c\"");
  CHECK(JsonString("l1\nl2\tx\r") == "\"l1\\nl2\\tx\\r\"");
  CHECK(JsonString(std::string("\x01\x1f", 2)) == "\"\\u0001\\u001f\"");
  CHECK(JsonString("caf\xc3\xa9") == "\"caf\xc3\xa9\"");
  CHECK(JsonString("</script>") == "\"</script>\"");
}

TEST_CASE("JsonString for an HTML script element escapes < > &") {
  CHECK(JsonString("</script>&", true) == "\"\\u003c/script\\u003e\\u0026\"");
  CHECK(JsonString("a\nb", true) == "\"a\\nb\"");
}

}  // namespace
}  // namespace vilma
