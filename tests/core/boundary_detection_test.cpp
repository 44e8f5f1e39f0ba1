#include "core/boundary_detection.hpp"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace terrain {
namespace {

TEST(BoundaryDetectionTest, BoxAgainstTheSkyGivesItsTopOnTheKnownRows) {
  // sky above row 100, a dark box from row 100 down in columns 60-180, and ground below row 200
  cv::Mat img(240, 320, CV_8UC3, cv::Scalar(200, 220, 255));
  cv::rectangle(img, cv::Rect(60, 100, 120, 140), cv::Scalar(60, 60, 70), cv::FILLED);
  cv::Mat speck = img.clone();
  speck.at<cv::Vec3b>(30, 250) = cv::Vec3b(0, 0, 0);  // one noisy pixel in the sky
  const BoundaryImages b = detectBoundaries(speck, BoundaryDetectionConfig{});
  // the box top: boundary pixels only on rows 99-100 (the kernel straddles the edge), in its columns
  for (int col = 70; col < 170; col += 10) {
    int first = -1;
    for (int row = 0; row < 240; ++row) {
      if (b.cleaned.at<std::uint8_t>(row, col)) {
        first = row;
        break;
      }
    }
    EXPECT_GE(first, 98) << col;
    EXPECT_LE(first, 100) << col;
  }
  // the speck is in the raw response and gone after erosion and dilation
  EXPECT_TRUE(b.raw.at<std::uint8_t>(30, 250) || b.raw.at<std::uint8_t>(29, 250));
  EXPECT_EQ(cv::countNonZero(b.cleaned(cv::Rect(230, 10, 40, 40))), 0);
  EXPECT_THROW(detectBoundaries(cv::Mat(), BoundaryDetectionConfig{}), std::invalid_argument);
}

TEST(BoundaryDetectionTest, ErosionInAllDirectionsKeepsASlopingEdge) {
  // a dark roof sloping at 45 degrees against the sky (its edge from (40, 160) up to (160, 40)),
  // and two single-pixel specks in the sky
  cv::Mat img(240, 320, CV_8UC1, cv::Scalar(220));
  const std::vector<cv::Point> roof{{40, 160}, {160, 40}, {280, 160}, {280, 239}, {40, 239}};
  cv::fillPoly(img, std::vector<std::vector<cv::Point>>{roof}, cv::Scalar(60));
  img.at<std::uint8_t>(20, 40) = 0;
  img.at<std::uint8_t>(30, 290) = 0;
  BoundaryDetectionConfig c;
  // boundary pixels within 2 px of the sloping edge's middle half, (70, 130) to (130, 70)
  auto on_edge = [](const cv::Mat& b) {
    int n = 0;
    for (int x = 70; x <= 130; ++x) {
      const int y = 200 - x;
      n += cv::countNonZero(b(cv::Rect(x, y - 2, 1, 5))) > 0;
    }
    return n;
  };
  c.erode_sloping = false;  // the one horizontal erosion when erode_all_directions is off
  for (const bool all : {true, false}) {
    c.erode_all_directions = all;
    const BoundaryImages b = detectBoundaries(img, c);
    EXPECT_EQ(on_edge(b.raw), 61);
    // kept in every column of it when eroding along all directions; a horizontal-only erosion
    // leaves nothing of a 45-degree edge one pixel wide per row
    if (all)
      EXPECT_EQ(on_edge(b.cleaned), 61);
    else
      EXPECT_LT(on_edge(b.cleaned), 10);
    // the specks go either way
    EXPECT_EQ(cv::countNonZero(b.cleaned(cv::Rect(30, 10, 20, 20))), 0) << all;
    EXPECT_EQ(cv::countNonZero(b.cleaned(cv::Rect(280, 20, 20, 20))), 0) << all;
  }
}

TEST(BoundaryDetectionTest, SlopingErosionKeepsAnObliqueRoofLineButNotACrownsOutline) {
  // a roof line seen obliquely, rising a row per column from (20, 150) to (120, 50), against the
  // sky, and two single-pixel specks in the sky
  const cv::Vec3b sky(150, 190, 240), facade(120, 100, 90), leaves(40, 110, 40);
  auto scene = [&](const cv::Vec3b& body) {
    cv::Mat img(200, 320, CV_8UC3, sky);
    const std::vector<cv::Point> roof{{20, 150}, {120, 50}, {300, 50}, {300, 199}, {20, 199}};
    cv::fillPoly(img, std::vector<std::vector<cv::Point>>{roof}, body);
    img.at<cv::Vec3b>(20, 40) = cv::Vec3b(0, 0, 0);
    img.at<cv::Vec3b>(30, 250) = cv::Vec3b(0, 0, 0);
    return img;
  };
  // columns of the roof line's middle, 40 to 100, with a boundary pixel within 2 rows of it
  auto on_line = [](const cv::Mat& b) {
    int n = 0;
    for (int x = 40; x <= 100; ++x) {
      const int y = 150 - (x - 20);
      n += cv::countNonZero(b(cv::Rect(x, y - 2, 1, 5))) > 0;
    }
    return n;
  };
  BoundaryDetectionConfig c;
  ASSERT_TRUE(c.erode_sloping);  // on by default
  const BoundaryImages sloping = detectBoundaries(scene(facade), c);
  EXPECT_EQ(on_line(sloping.raw), 61);
  EXPECT_EQ(on_line(sloping.cleaned), 61);
  c.erode_sloping = false;
  const BoundaryImages level = detectBoundaries(scene(facade), c);
  EXPECT_EQ(on_line(level.raw), 61);
  // a run of a pixel or two per row: the horizontal mask leaves little of it
  EXPECT_LT(on_line(level.cleaned), 10) << on_line(level.cleaned);
  // the specks go either way
  for (const BoundaryImages* b : {&sloping, &level}) {
    EXPECT_EQ(cv::countNonZero(b->cleaned(cv::Rect(30, 10, 20, 20))), 0);
    EXPECT_EQ(cv::countNonZero(b->cleaned(cv::Rect(240, 20, 20, 20))), 0);
  }
  // the same outline in foliage colours is left to the horizontal mask
  c.erode_sloping = true;
  const BoundaryImages crown = detectBoundaries(scene(leaves), c);
  EXPECT_EQ(on_line(crown.raw), 61);
  c.erode_sloping = false;
  EXPECT_EQ(on_line(crown.cleaned), on_line(detectBoundaries(scene(leaves), c).cleaned));
}

TEST(BoundaryDetectionTest, FoliageMaskFollowsThePerPixelRule) {
  // every red and blue level against green levels around them, margins of 0, 10 and 40
  cv::Mat rgb(256, 256 * 3, CV_8UC3);
  for (int r = 0; r < 256; ++r) {
    for (int x = 0; x < rgb.cols; ++x) {
      const int g = x % 256, b = (x / 256) * 120;
      rgb.at<cv::Vec3b>(r, x) =
          cv::Vec3b(static_cast<std::uint8_t>(r), static_cast<std::uint8_t>(g), static_cast<std::uint8_t>(b));
    }
  }
  for (const int margin : {0, 10, 40}) {
    const cv::Mat mask = foliageMask(rgb, margin);
    ASSERT_EQ(mask.type(), CV_8UC1);
    int disagree = 0, foliage = 0;
    for (int v = 0; v < rgb.rows; ++v) {
      for (int u = 0; u < rgb.cols; ++u) {
        const bool rule = looksLikeFoliage(rgb.at<cv::Vec3b>(v, u), margin);
        disagree += rule != (mask.at<std::uint8_t>(v, u) == 255);
        foliage += rule;
      }
    }
    EXPECT_EQ(disagree, 0) << "margin " << margin;
    EXPECT_GT(foliage, 0) << "margin " << margin;
  }
  // the rule itself, by hand: green 10 above red and blue is foliage at margin 10, 9 above is not
  EXPECT_TRUE(looksLikeFoliage(cv::Vec3b(40, 50, 40), 10));
  EXPECT_FALSE(looksLikeFoliage(cv::Vec3b(41, 50, 40), 10));
  EXPECT_FALSE(looksLikeFoliage(cv::Vec3b(40, 50, 41), 10));
  EXPECT_THROW(foliageMask(cv::Mat(4, 4, CV_8UC1, cv::Scalar(0)), 10), std::invalid_argument);
}

TEST(BoundaryDetectionTest, VerticalChangesWeighMoreThanHorizontal) {
  cv::Mat horizontal_edge(50, 50, CV_8UC1, cv::Scalar(0)), vertical_edge(50, 50, CV_8UC1, cv::Scalar(0));
  horizontal_edge(cv::Rect(0, 25, 50, 25)).setTo(100);
  vertical_edge(cv::Rect(25, 0, 25, 50)).setTo(100);
  const BoundaryDetectionConfig c;  // kx < ky
  double mh = 0, mv = 0;
  cv::minMaxLoc(detectBoundaries(horizontal_edge, c).magnitude, nullptr, &mh);
  cv::minMaxLoc(detectBoundaries(vertical_edge, c).magnitude, nullptr, &mv);
  // same step: (a + b + a) * 100 = 400 per kernel; weights sqrt(ky) and sqrt(kx)
  EXPECT_NEAR(mh, 400 * std::sqrt(c.ky), 1e-3);
  EXPECT_NEAR(mv, 400 * std::sqrt(c.kx), 1e-3);
}

}  // namespace
}  // namespace terrain
