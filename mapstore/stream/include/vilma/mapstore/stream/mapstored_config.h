// vilma-mapstored's configuration file (--config FILE): one plain struct, read strictly (unknown
// key -> error naming file, key and the known keys; a missing key keeps its default) and written
// back by the same field list (core/options_fields.h), so that every config round-trips.
#pragma once

#include <string>

#include "vilma/core/yaml_io.h"
#include "vilma/mapstore/stream/map_store_server.h"
#include "vilma/mapstore/stream/mission_post_processor.h"

namespace vilma::mapstore {

struct MapstoredConfig {
  double incomplete_timeout_s = 0.0;  // finalize a silent mission as incomplete after this [s]; 0: never
  bool finalize_incomplete_at_shutdown = false;
  int max_reorder_chunks = 1024;      // out-of-order chunks kept per mission
  int max_reorder_mib = 256;          // out-of-order payload kept per mission [MiB], >= 64
  int max_ack_batch = 256;            // chunks handled between two fsync + ack rounds
  std::string post_process_script;    // console script run on every finished mission; "": none;
                                      // a relative path is relative to the config file
  double post_process_timeout_s = 3600.0;
  std::string vilma_program;          // the `vilma` executable; "": vilma beside vilma-mapstored

  std::string Validate() const;  // "" or "field: expectation"

  // The server's options for maps under `root` (the save options keep their defaults).
  MapStoreServerOptions ServerOptions(const std::string& root) const;
  // The post-processor's options; `default_vilma_program` when vilma_program is "".
  PostProcessOptions PostProcess(const std::string& default_vilma_program) const;
};

// Reads `node` (a map; missing keys keep the defaults) and validates. A relative
// post_process_script is resolved against the folder of node.file().
MapstoredConfig ReadMapstoredConfig(const YamlNode& node);
MapstoredConfig LoadMapstoredConfig(const std::string& path);
// Every field as YAML that ReadMapstoredConfig reads back to equal values.
std::string MapstoredConfigToYaml(const MapstoredConfig& config);

}  // namespace vilma::mapstore
