#include "dbacov/app/pipeline.h"

#include <atomic>
#include <exception>
#include <mutex>

#include <tbb/parallel_pipeline.h>

#include "allocator_reuse.h"

namespace dbacov::app {

void runSnapshotPipeline(SnapshotStream& stream, std::size_t in_flight,
                         const std::function<void(PipelineItem&)>& compute,
                         const std::function<bool(PipelineItem&)>& consume) {
  keepFreedMemoryForReuse();
  using Ptr = std::shared_ptr<PipelineItem>;
  // No exception may leave a filter: TBB would cancel the pipeline and drop (leak) the items in
  // flight. A failure stops the pipeline instead, and is rethrown once it has drained.
  std::atomic<bool> stop{false};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  auto fail = [&] {
    const std::lock_guard<std::mutex> lock(failure_mutex);
    if (!failure) failure = std::current_exception();
    stop = true;
  };
  tbb::parallel_pipeline(
      std::max<std::size_t>(1, in_flight),
      tbb::make_filter<void, Ptr>(tbb::filter_mode::serial_in_order,
                                  [&](tbb::flow_control& fc) -> Ptr {
                                    auto item = std::make_shared<PipelineItem>();
                                    try {
                                      if (!stop && stream.next(&item->input)) return item;
                                    } catch (...) {
                                      fail();
                                    }
                                    fc.stop();
                                    return nullptr;
                                  }) &
          tbb::make_filter<Ptr, Ptr>(tbb::filter_mode::parallel,
                                     [&](Ptr item) {
                                       try {
                                         if (stop) return item;
                                         loadPending(&item->input);  // a deferred .npz
                                         if (item->input.ok()) compute(*item);
                                       } catch (...) {
                                         fail();
                                       }
                                       return item;
                                     }) &
          tbb::make_filter<Ptr, void>(tbb::filter_mode::serial_in_order, [&](Ptr item) {
            try {
              if (!stop && !consume(*item)) stop = true;
            } catch (...) {
              fail();
            }
          }));
  if (failure) std::rethrow_exception(failure);
}

}  // namespace dbacov::app
