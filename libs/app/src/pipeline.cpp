#include "dbacov/app/pipeline.h"

#include <tbb/parallel_pipeline.h>

namespace dbacov::app {

void runSnapshotPipeline(SnapshotStream& stream, std::size_t in_flight,
                         const std::function<void(PipelineItem&)>& compute,
                         const std::function<void(PipelineItem&)>& consume) {
  using Ptr = std::shared_ptr<PipelineItem>;
  tbb::parallel_pipeline(
      std::max<std::size_t>(1, in_flight),
      tbb::make_filter<void, Ptr>(tbb::filter_mode::serial_in_order,
                                  [&](tbb::flow_control& fc) -> Ptr {
                                    auto item = std::make_shared<PipelineItem>();
                                    if (!stream.next(&item->input)) {
                                      fc.stop();
                                      return nullptr;
                                    }
                                    return item;
                                  }) &
          tbb::make_filter<Ptr, Ptr>(tbb::filter_mode::parallel,
                                     [&](Ptr item) {
                                       if (item->input.ok()) compute(*item);
                                       return item;
                                     }) &
          tbb::make_filter<Ptr, void>(tbb::filter_mode::serial_in_order,
                                      [&](Ptr item) { consume(*item); }));
}

}  // namespace dbacov::app
