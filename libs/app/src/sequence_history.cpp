#include "dbacov/app/sequence_history.h"

#include <algorithm>

namespace dbacov::app {

std::vector<int> SequenceHistory::add(const Snapshot& s, const DbaCovariance& cov) {
  ++snapshots_;
  const std::vector<int> gauge = cov.gaugeKeyframes();
  std::vector<int> updated;
  for (int k : cov.keyframes()) {
    const bool is_gauge = std::find(gauge.begin(), gauge.end(), k) != gauge.end();
    const auto it = records_.find(s.tstamp[k]);
    // A gauge observation never replaces a non-gauge one (see the header).
    if (it != records_.end() && is_gauge && !it->second.gauge) continue;
    KeyframeRecord r;
    r.tstamp = s.tstamp[k];
    if (s.timestamps_s) r.time_s = (*s.timestamps_s)[k];
    r.keyframe = k;
    r.snapshot = s.label();
    r.T_wc = cov.T_wc(k);
    r.Sigma = cov.marginal(k);
    r.gauge = is_gauge;
    records_.insert_or_assign(r.tstamp, r);
    updated.push_back(k);
  }
  last_edges_.clear();
  for (int e = 0; e < s.numEdges(); ++e) {
    const std::pair<double, double> edge{s.tstamp[s.ii[e]], s.tstamp[s.jj[e]]};
    edges_.insert(edge);
    last_edges_.insert(edge);
  }
  return updated;
}

std::vector<KeyframeRecord> SequenceHistory::keyframes() const {
  std::vector<KeyframeRecord> out;
  out.reserve(records_.size());
  for (const auto& [t, r] : records_) out.push_back(r);
  return out;
}

int SequenceHistory::sequenceNumber(double tstamp) const {
  const auto it = records_.find(tstamp);
  return it == records_.end() ? -1 : static_cast<int>(std::distance(records_.begin(), it));
}

bool SequenceHistory::hasTimes() const {
  if (records_.empty()) return false;
  for (const auto& [t, r] : records_)
    if (!r.time_s) return false;
  return true;
}

std::vector<std::pair<int, int>> SequenceHistory::toNumbers(
    const std::set<std::pair<double, double>>& e) const {
  std::map<double, int> number;
  for (const auto& [t, r] : records_) number.emplace(t, static_cast<int>(number.size()));
  std::vector<std::pair<int, int>> out;
  out.reserve(e.size());
  for (const auto& [a, b] : e) {
    const auto i = number.find(a), j = number.find(b);
    if (i != number.end() && j != number.end()) out.emplace_back(i->second, j->second);
  }
  return out;
}

}  // namespace dbacov::app
