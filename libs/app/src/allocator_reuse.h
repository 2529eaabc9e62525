// Private to dbacov_app: keep freed snapshot buffers for the next snapshot.
#pragma once

namespace dbacov::app {

/// Once per process: glibc's malloc serves the multi-megabyte buffers of each snapshot (inflated
/// members, arrays, linearization) from its heap instead of fresh mmap()s, and keeps freed memory
/// instead of returning it to the system after every snapshot. Every snapshot after the first
/// then reuses pages already mapped instead of faulting in and zeroing new ones (31 000 → 7 000
/// page faults for 20 snapshots). The peak stays that of the largest snapshots in flight. The
/// main heap is also grown by ≈ 128 MiB at once and that region advised for transparent huge
/// pages (madvise), so that a first snapshot on the main thread faults in 2 MiB pages instead of
/// 4 KiB ones. That matters where faults are expensive (≈ 20 µs each in a paravirtualized guest:
/// the shared snapshot's whole run 58 → 42 ms of CPU, with --self-calibrate 211 → 135 ms;
/// docs/development/performance.md). No-op without glibc.
void keepFreedMemoryForReuse();

}  // namespace dbacov::app
