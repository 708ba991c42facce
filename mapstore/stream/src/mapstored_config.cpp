#include "vilma/mapstore/stream/mapstored_config.h"

#include <filesystem>

#include "vilma/core/error.h"
#include "vilma/core/options_fields.h"

namespace vilma::mapstore {
namespace {

// One list of every field: reader and writer stay in sync (core/options_fields.h).
template <typename Config, typename Visitor>
void VisitMapstoredConfig(Config& c, Visitor&& v) {
  v("", "incomplete_timeout_s", c.incomplete_timeout_s);
  v("", "finalize_incomplete_at_shutdown", c.finalize_incomplete_at_shutdown);
  v("", "max_reorder_chunks", c.max_reorder_chunks);
  v("", "max_reorder_mib", c.max_reorder_mib);
  v("", "max_ack_batch", c.max_ack_batch);
  v("", "post_process_script", c.post_process_script);
  v("", "post_process_timeout_s", c.post_process_timeout_s);
  v("", "vilma_program", c.vilma_program);
}

}  // namespace

std::string MapstoredConfig::Validate() const {
  if (!(incomplete_timeout_s >= 0.0)) return "incomplete_timeout_s: expected a number >= 0";
  if (max_reorder_chunks < 1) return "max_reorder_chunks: expected an integer >= 1";
  if (max_reorder_mib < 64 || max_reorder_mib > 65536) {
    return "max_reorder_mib: expected an integer in [64, 65536] (MiB; a chunk may hold 64 MiB)";
  }
  if (max_ack_batch < 1) return "max_ack_batch: expected an integer >= 1";
  if (!post_process_script.empty() && !std::filesystem::is_regular_file(post_process_script)) {
    return "post_process_script: expected an existing console script file (" +
           post_process_script + ")";
  }
  if (!(post_process_timeout_s > 0.0)) return "post_process_timeout_s: expected a number > 0";
  // The program itself is checked when the post-processor starts (MissionPostProcessor).
  return "";
}

MapStoreServerOptions MapstoredConfig::ServerOptions(const std::string& root) const {
  MapStoreServerOptions options;
  options.root = root;
  options.incomplete_timeout_s = incomplete_timeout_s;
  options.finalize_incomplete_at_shutdown = finalize_incomplete_at_shutdown;
  options.max_reorder_chunks = static_cast<std::size_t>(max_reorder_chunks);
  options.max_reorder_bytes = static_cast<std::size_t>(max_reorder_mib) << 20;
  return options;
}

PostProcessOptions MapstoredConfig::PostProcess(const std::string& default_vilma_program) const {
  PostProcessOptions options;
  options.script = post_process_script;
  options.timeout_s = post_process_timeout_s;
  options.vilma_program = vilma_program.empty() ? default_vilma_program : vilma_program;
  return options;
}

MapstoredConfig ReadMapstoredConfig(const YamlNode& node) {
  MapstoredConfig config;
  ReadOptionFields(node, MissingKey::kKeepDefault, &config,
                   [](auto& c, auto&& v) { VisitMapstoredConfig(c, v); });
  if (!config.post_process_script.empty() && config.post_process_script[0] != '/') {
    // Absolute, so that --print-config's output reads back the same from any folder.
    config.post_process_script =
        std::filesystem::absolute(std::filesystem::path(node.file()).parent_path() /
                                  config.post_process_script)
            .lexically_normal()
            .string();
  }
  node.CheckValid(config.Validate());
  return config;
}

MapstoredConfig LoadMapstoredConfig(const std::string& path) {
  return ReadMapstoredConfig(YamlNode::LoadFile(path));
}

std::string MapstoredConfigToYaml(const MapstoredConfig& config) {
  return OptionFieldsToYaml(config, [](auto& c, auto&& v) { VisitMapstoredConfig(c, v); });
}

}  // namespace vilma::mapstore
