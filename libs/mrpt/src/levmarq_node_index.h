// The free-node look-up of MRPT's levmarq in O(log n) instead of O(n).
//
// MRPT 2.5.8's optimize_graph_spa_levmarq (a header template, instantiated in bridge_impl.cpp)
// finds the position of each edge's two nodes among the free nodes with
// mrpt::containers::find_in_vector, which walks the std::set of free nodes from its start: O(n)
// per edge, O(n · edges) in all. On a chain of 40 000 nodes this walk was 88 % of dba-posegraph's
// time, and the cost grew quadratically. Below, that one instantiation (a node id in a
// std::set of node ids) is specialized: while a FreeNodeIndex scope is active for the set, the
// position is a binary search in a sorted copy of it; any other set falls back to MRPT's walk.
// The result is the same position, so the optimizer's arithmetic is unchanged.
//
// Include this header before <mrpt/graphslam/levmarq.h>.
#pragma once

#include <algorithm>
#include <set>
#include <string>
#include <vector>

#include <mrpt/containers/stl_containers_utils.h>
#include <mrpt/graphs/TNodeID.h>

namespace dbacov::mrpt_bridge {

/// The sorted free-node ids of one optimize_graph_spa_levmarq call, active on this thread for
/// the lifetime of the object (scopes do not nest).
class FreeNodeIndex {
 public:
  explicit FreeNodeIndex(const std::set<mrpt::graphs::TNodeID>& free)
      : set_(&free), sorted_(free.begin(), free.end()) {
    active_ = this;
  }
  ~FreeNodeIndex() { active_ = nullptr; }
  FreeNodeIndex(const FreeNodeIndex&) = delete;
  FreeNodeIndex& operator=(const FreeNodeIndex&) = delete;

  /// The index for `free`, if one is active for exactly that set; else nullptr.
  static const FreeNodeIndex* activeFor(const std::set<mrpt::graphs::TNodeID>& free) {
    return active_ && active_->set_ == &free ? active_ : nullptr;
  }

  /// The position of `id` in the set, or std::string::npos when it is not in it.
  std::size_t position(mrpt::graphs::TNodeID id) const {
    const auto it = std::lower_bound(sorted_.begin(), sorted_.end(), id);
    return it != sorted_.end() && *it == id ? static_cast<std::size_t>(it - sorted_.begin())
                                            : std::string::npos;
  }

 private:
  const std::set<mrpt::graphs::TNodeID>* set_;
  std::vector<mrpt::graphs::TNodeID> sorted_;
  static inline thread_local const FreeNodeIndex* active_ = nullptr;
};

}  // namespace dbacov::mrpt_bridge

namespace mrpt::containers {

template <>
inline std::size_t find_in_vector(const mrpt::graphs::TNodeID& value,
                                  const std::set<mrpt::graphs::TNodeID>& ids) {
  if (const auto* index = dbacov::mrpt_bridge::FreeNodeIndex::activeFor(ids))
    return index->position(value);
  std::size_t k = 0;  // MRPT's own walk
  for (const mrpt::graphs::TNodeID id : ids) {
    if (id == value) return k;
    ++k;
  }
  return std::string::npos;
}

}  // namespace mrpt::containers
