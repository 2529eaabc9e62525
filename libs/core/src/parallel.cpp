#include "dbacov/core/parallel.h"

#include "dbacov/core/kernel_isa.h"
#include "dbacov/core/threads.h"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <thread>
#include <utility>

namespace dbacov {
namespace {

// The innermost ScopedInterruptCheck of each thread.
thread_local ScopedInterruptCheck* t_interrupt = nullptr;

/// Hides this thread's check while it lives (when `hide`).
class HideInterruptCheck {
 public:
  explicit HideInterruptCheck(bool hide) : saved_(t_interrupt), hide_(hide) {
    if (hide_) t_interrupt = nullptr;
  }
  ~HideInterruptCheck() {
    if (hide_) t_interrupt = saved_;
  }
  HideInterruptCheck(const HideInterruptCheck&) = delete;
  HideInterruptCheck& operator=(const HideInterruptCheck&) = delete;

 private:
  ScopedInterruptCheck* saved_;
  bool hide_;
};

}  // namespace

ScopedInterruptCheck::ScopedInterruptCheck(std::function<void()> check,
                                           std::chrono::milliseconds period)
    : check_(std::move(check)),
      period_(period),
      last_(std::chrono::steady_clock::now()),
      outer_(t_interrupt) {
  t_interrupt = this;
}

ScopedInterruptCheck::~ScopedInterruptCheck() {
  t_interrupt = outer_;
}

void ScopedInterruptCheck::poll(bool now) {
  ScopedInterruptCheck* c = t_interrupt;
  if (!c || !c->check_) return;
  const auto t = std::chrono::steady_clock::now();
  if (!now && t - c->last_ < c->period_) return;
  c->last_ = t;
  c->check_();
}

void parallelFor(std::size_t n, const std::function<void(std::size_t)>& fn) {
  // The interrupt check runs on the thread that installed it only: TBB's calling thread takes
  // part in the loop, so a long loop is checked between its items, not just before it.
  const bool checked = t_interrupt != nullptr;
  if (checked) ScopedInterruptCheck::poll(true);
  if (n == 1) {
    fn(0);
    return;
  }
  const std::thread::id owner = std::this_thread::get_id();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      // Another thread's work (TBB lets a waiting thread steal it) is never
                      // stopped by this thread's check: it is hidden while the items run.
                      const bool mine = std::this_thread::get_id() == owner;
                      const HideInterruptCheck hide(!mine);
                      for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        if (checked && mine) ScopedInterruptCheck::poll();
                        fn(i);
                      }
                    });
}

struct ThreadLimit::Impl {
  std::unique_ptr<tbb::global_control> control;
};

ThreadLimit::ThreadLimit(std::size_t threads) : impl_(std::make_unique<Impl>()) {
  if (threads > 0)
    impl_->control = std::make_unique<tbb::global_control>(
        tbb::global_control::max_allowed_parallelism, threads);
}

ThreadLimit::~ThreadLimit() = default;

void checkEngineEnvironment() {
  static_cast<void>(kernel::selectedIsa());
}

std::size_t currentThreadLimit() {
  return tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
}

}  // namespace dbacov
