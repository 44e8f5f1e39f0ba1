#include "evaluation/metrics.hpp"

#include <algorithm>
#include <cmath>

namespace terrain::eval {

BinaryScores binaryScores(std::size_t tp, std::size_t fp, std::size_t fn, std::size_t tn) {
  BinaryScores s{tp, fp, fn, tn};
  const auto ratio = [](double a, double b) { return b > 0 ? a / b : 0.0; };
  s.precision = ratio(tp, tp + fp);
  s.recall = ratio(tp, tp + fn);
  s.f1 = ratio(2.0 * tp, 2.0 * tp + fp + fn);
  s.iou = ratio(tp, tp + fp + fn);
  return s;
}

BinaryScores binaryScores(const std::vector<bool>& predicted, const std::vector<bool>& truth,
                          const std::vector<bool>& skip) {
  std::size_t tp = 0, fp = 0, fn = 0, tn = 0;
  for (std::size_t i = 0; i < std::min(predicted.size(), truth.size()); ++i) {
    if (!skip.empty() && skip[i]) continue;
    if (predicted[i] && truth[i])
      ++tp;
    else if (predicted[i])
      ++fp;
    else if (truth[i])
      ++fn;
    else
      ++tn;
  }
  return binaryScores(tp, fp, fn, tn);
}

ErrorStats errorStats(const std::vector<double>& errors) {
  ErrorStats s;
  s.count = errors.size();
  if (errors.empty()) return s;
  double sum = 0, sum_abs = 0, sum2 = 0;
  for (double e : errors) sum += e, sum_abs += std::abs(e), sum2 += e * e;
  const double n = static_cast<double>(errors.size());
  s.bias = sum / n;
  s.mae = sum_abs / n;
  s.rmse = std::sqrt(sum2 / n);
  double var = 0;
  for (double e : errors) var += (e - s.bias) * (e - s.bias);
  s.variance = var / n;
  return s;
}

Percentiles percentiles(std::vector<double> v) {
  Percentiles p;
  if (v.empty()) return p;
  std::sort(v.begin(), v.end());
  p.median = v[(v.size() - 1) / 2];
  const std::size_t rank = static_cast<std::size_t>(std::ceil(0.95 * v.size()));
  p.p95 = v[std::max<std::size_t>(1, rank) - 1];
  return p;
}

PoseError poseError(const Pose& estimated, const Pose& truth) {
  PoseError e;
  const Vector3 d = estimated.translation() - truth.translation();
  e.horizontal = d.head<2>().norm();
  e.vertical = std::abs(d.z());
  const Vector3 fe = estimated.linear() * Vector3::UnitX(), ft = truth.linear() * Vector3::UnitX();
  const Vector3 le = estimated.linear() * Vector3::UnitY(), lt = truth.linear() * Vector3::UnitY();
  const auto elevation = [](const Vector3& v) { return std::asin(std::clamp(v.z(), -1.0, 1.0)); };
  e.heading = std::abs(std::remainder(std::atan2(fe.y(), fe.x()) - std::atan2(ft.y(), ft.x()), 2 * M_PI));
  e.pitch = std::abs(elevation(fe) - elevation(ft));
  e.roll = std::abs(elevation(le) - elevation(lt));
  return e;
}

}  // namespace terrain::eval
