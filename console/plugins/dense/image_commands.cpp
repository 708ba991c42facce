// Images in maps (mapping/dense, docs/dense.md "Images in maps"): attach_images.
#include "vilma/console/command_registry.h"
#include "vilma/mapping/dense/image_attachment.h"
#include "vilma/mapping/inspection/map_statistics.h"

namespace vilma::console {
namespace {

struct AttachImagesOptions : mapping::ImageAttachmentOptions {
  std::string map_mission;
};

void Register(CommandRegistry* registry) {
  using O = AttachImagesOptions;
  registry->Add(
      Command<O>("attach_images")
          .Group("dense")
          .Summary("store the images of an ASL / EuRoC dataset in the map: per vertex and rig "
                   "camera i the nearest mav0/cam<i> image in time, as a PNG image resource")
          .Usage("[DATASET]")
          .Access(MapAccess::kModify)
          .PathFlag("dataset", &O::dataset,
                    "ASL / EuRoC dataset folder (with mav0/cam0, mav0/cam1, ...; PNG or JPEG)")
          .Positional("dataset")
          .Flag("max_time_difference_s", &O::max_time_difference_s,
                "an image belongs to a vertex camera when its stamp is at most this far from "
                "the vertex time minus the camera's time offset [s] (default 1 ms)")
          .Flag("overwrite", &O::overwrite,
                "replace the images of frames that already have one (default: keep them)")
          .Flag("map_mission", &O::map_mission,
                "missions: ids, unique prefixes or names, comma separated (default: all)",
                {"mission"})
          .Run([](CommandContext& c, const O& o) {
            const std::vector<mapstore::MissionId> missions =
                mapping::ResolveMissions(c.map(), o.map_mission);
            const mapping::ImageAttachmentSummary summary =
                mapping::AttachImages(o, missions, &c.map(), c.progress());
            c.out() << summary.FullReport();
          }));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)
