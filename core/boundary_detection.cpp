#include "core/boundary_detection.hpp"

#include <opencv2/imgproc.hpp>

#include <stdexcept>

namespace terrain {

BoundaryImages detectBoundaries(const cv::Mat& image, const BoundaryDetectionConfig& c) {
  if (image.empty()) throw std::invalid_argument("boundary detection: empty image");
  cv::Mat grey;
  if (image.type() == CV_8UC3) {
    cv::cvtColor(image, grey, cv::COLOR_RGB2GRAY);
  } else if (image.type() == CV_8UC1) {
    grey = image;
  } else {
    throw std::invalid_argument("boundary detection: expected an 8-bit RGB or grey image");
  }
  cv::Mat p;
  grey.convertTo(p, CV_32F);
  // Figure 6, with image rows growing downwards: Lx = right column - left column,
  // Ly = row above - row below (Eqs. 2 and 3)
  const cv::Mat horizontal = (cv::Mat_<float>(3, 3) << -c.a, 0, c.a, -c.b, 0, c.b, -c.a, 0, c.a);
  const cv::Mat vertical = (cv::Mat_<float>(3, 3) << c.a, c.b, c.a, 0, 0, 0, -c.a, -c.b, -c.a);
  cv::Mat lx, ly;
  cv::filter2D(p, lx, CV_32F, horizontal, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
  cv::filter2D(p, ly, CV_32F, vertical, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
  BoundaryImages out;
  cv::Mat lx2, ly2;
  cv::multiply(lx, lx, lx2, c.kx);
  cv::multiply(ly, ly, ly2, c.ky);
  cv::sqrt(lx2 + ly2, out.magnitude);
  out.raw = out.magnitude > c.threshold;
  // erosion drops isolated responses, dilation restores the boundaries that survive
  const cv::Mat dilate_mask = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(c.dilate_width, c.dilate_height));
  cv::Mat eroded;
  if (c.erode_all_directions) {
    const int n = c.erode_width;
    eroded = cv::Mat::zeros(out.raw.size(), CV_8UC1);
    cv::Mat line_h = cv::Mat::ones(1, n, CV_8UC1), line_v = cv::Mat::ones(n, 1, CV_8UC1);
    cv::Mat diag = cv::Mat::eye(n, n, CV_8UC1), anti;
    cv::flip(diag, anti, 1);
    cv::Mat opened;
    for (const cv::Mat* mask : {&line_h, &line_v, &diag, &anti}) {
      cv::morphologyEx(out.raw, opened, cv::MORPH_OPEN, *mask);
      eroded |= opened;
    }
  } else {
    cv::erode(out.raw, eroded, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(c.erode_width, c.erode_height)));
  }
  cv::dilate(eroded, out.cleaned, dilate_mask);
  return out;
}

}  // namespace terrain
