#include "evaluation/baselines.hpp"

#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>
#include <pcl/ModelCoefficients.h>
#include <pcl/point_types.h>
#include <pcl/segmentation/progressive_morphological_filter.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <cmath>
#include <limits>

namespace terrain::eval {

namespace {

pcl::PointCloud<pcl::PointXYZ>::Ptr toCloud(const std::vector<Point3>& points) {
  auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  cloud->reserve(points.size());
  for (const auto& p : points) cloud->push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
  return cloud;
}

}  // namespace

std::vector<std::uint8_t> groundByFixedBand(const std::vector<Point3>& points, const std::vector<Point3>& ground,
                                            double delta) {
  std::vector<std::uint8_t> out(points.size(), 0);
  if (ground.empty()) return out;
  // nearest trajectory position on a coarse grid of the trajectory: the trajectory is short, so a
  // linear scan over a thinned copy is enough
  std::vector<Point3> thin;
  for (const auto& g : ground) {
    if (thin.empty() || (g - thin.back()).head<2>().norm() > 0.5) thin.push_back(g);
  }
  for (std::size_t i = 0; i < points.size(); ++i) {
    double best = std::numeric_limits<double>::infinity(), z = 0;
    for (const auto& g : thin) {
      const double d = (points[i] - g).head<2>().squaredNorm();
      if (d < best) best = d, z = g.z();
    }
    out[i] = std::abs(points[i].z() - z) <= delta;
  }
  return out;
}

std::vector<std::uint8_t> groundByRansacPlane(const std::vector<Point3>& points, double distance_threshold) {
  std::vector<std::uint8_t> out(points.size(), 0);
  if (points.size() < 3) return out;
  pcl::SACSegmentation<pcl::PointXYZ> seg;
  seg.setOptimizeCoefficients(true);
  seg.setModelType(pcl::SACMODEL_PLANE);
  seg.setMethodType(pcl::SAC_RANSAC);
  seg.setDistanceThreshold(distance_threshold);
  seg.setMaxIterations(200);
  seg.setInputCloud(toCloud(points));
  pcl::PointIndices inliers;
  pcl::ModelCoefficients coefficients;
  seg.segment(inliers, coefficients);
  for (int i : inliers.indices) out[i] = 1;
  return out;
}

std::vector<std::uint8_t> groundByMorphologicalFilter(const std::vector<Point3>& points,
                                                      const MorphologicalFilterConfig& c) {
  std::vector<std::uint8_t> out(points.size(), 0);
  if (points.empty()) return out;
  pcl::ProgressiveMorphologicalFilter<pcl::PointXYZ> pmf;
  pmf.setInputCloud(toCloud(points));
  pmf.setMaxWindowSize(c.max_window_size);
  pmf.setSlope(c.slope);
  pmf.setInitialDistance(c.initial_distance);
  pmf.setMaxDistance(c.max_distance);
  pmf.setCellSize(c.cell_size);
  std::vector<int> ground;
  pmf.extract(ground);
  for (int i : ground) out[i] = 1;
  return out;
}

cv::Mat inpaintHeights(const cv::Mat& heights, int radius) {
  cv::Mat filled = heights.clone(), mask(heights.size(), CV_8UC1, cv::Scalar(0));
  cv::Mat known(heights.size(), CV_8UC1, cv::Scalar(0));
  for (int r = 0; r < heights.rows; ++r) {
    for (int c = 0; c < heights.cols; ++c) {
      const float h = heights.at<float>(r, c);
      if (std::isfinite(h)) known.at<std::uint8_t>(r, c) = 255;
      else filled.at<float>(r, c) = 0.0f;
    }
  }
  // holes near data only: the dilated data mask minus the data
  cv::Mat near;
  cv::dilate(known, near, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * radius + 1, 2 * radius + 1)));
  mask = near & ~known;
  cv::Mat out;
  cv::inpaint(filled, mask, out, radius, cv::INPAINT_TELEA);
  for (int r = 0; r < out.rows; ++r) {
    for (int c = 0; c < out.cols; ++c) {
      if (!near.at<std::uint8_t>(r, c)) out.at<float>(r, c) = std::numeric_limits<float>::quiet_NaN();
    }
  }
  return out;
}

}  // namespace terrain::eval
