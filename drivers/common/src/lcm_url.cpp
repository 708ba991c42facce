#include "vilma/drivers/lcm_url.h"

#include <cstdlib>

namespace vilma {

std::string DefaultLcmUrl() {
  const char* env = std::getenv("LCM_DEFAULT_URL");
  if (env != nullptr && env[0] != '\0') return env;
  return kDefaultLcmUrl;
}

std::string ResolveLcmUrl(const std::string& url) { return url.empty() ? DefaultLcmUrl() : url; }

namespace {

// Calls f(begin, end) for each "key=value" item of the query part of `url`, with [begin, end)
// the item's character range; stops when f returns true. Returns the position of '?' or npos.
template <typename F>
size_t ForEachQueryItem(const std::string& url, F f) {
  const size_t q = url.find('?');
  if (q == std::string::npos) return q;
  size_t begin = q + 1;
  while (begin <= url.size()) {
    size_t end = url.find('&', begin);
    if (end == std::string::npos) end = url.size();
    if (end > begin && f(begin, end)) break;
    begin = end + 1;
  }
  return q;
}

bool ItemHasKey(const std::string& url, size_t begin, size_t end, const std::string& key) {
  const size_t eq = url.find('=', begin);
  const size_t key_end = (eq == std::string::npos || eq > end) ? end : eq;
  return url.compare(begin, key_end - begin, key) == 0 && key_end - begin == key.size();
}

}  // namespace

std::string LcmUrlParameter(const std::string& url, const std::string& key) {
  std::string value;
  ForEachQueryItem(url, [&](size_t begin, size_t end) {
    if (!ItemHasKey(url, begin, end, key)) return false;
    const size_t eq = url.find('=', begin);
    if (eq != std::string::npos && eq < end) value = url.substr(eq + 1, end - eq - 1);
    return true;
  });
  return value;
}

std::string WithLcmUrlParameter(const std::string& url, const std::string& key,
                                const std::string& value) {
  size_t found_begin = std::string::npos, found_end = std::string::npos;
  const size_t q = ForEachQueryItem(url, [&](size_t begin, size_t end) {
    if (!ItemHasKey(url, begin, end, key)) return false;
    found_begin = begin;
    found_end = end;
    return true;
  });
  const std::string item = key + "=" + value;
  if (found_begin != std::string::npos) {
    return url.substr(0, found_begin) + item + url.substr(found_end);
  }
  if (q == std::string::npos) return url + "?" + item;
  if (q + 1 == url.size() || url.back() == '&') return url + item;
  return url + "&" + item;
}

std::string WithDefaultRecvBufSize(const std::string& url, int64_t bytes) {
  if (url.rfind("udpm://", 0) != 0) return url;
  if (!LcmUrlParameter(url, "recv_buf_size").empty()) return url;
  return WithLcmUrlParameter(url, "recv_buf_size", std::to_string(bytes));
}

std::string ChannelName(const std::string& base, const std::string& suffix) {
  return base + suffix;
}

}  // namespace vilma
