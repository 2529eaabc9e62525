#include "dbacov/flow/opencv_flow.h"

#include <algorithm>
#include <memory>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "dbacov/sim/image_flow.h"

namespace dbacov::flow {
namespace {

cv::Mat toMat8(const sim::GrayImage& img) {
  cv::Mat m(img.H, img.W, CV_8UC1);
  for (int y = 0; y < img.H; ++y)
    for (int x = 0; x < img.W; ++x)
      m.at<unsigned char>(y, x) = cv::saturate_cast<uchar>(img.at(x, y));
  return m;
}

cv::Mat toFlowMat(const sim::FlowField& f) {
  cv::Mat m(f.H, f.W, CV_32FC2);
  for (int y = 0; y < f.H; ++y)
    for (int x = 0; x < f.W; ++x) {
      const std::size_t p = static_cast<std::size_t>(y) * f.W + x;
      m.at<cv::Point2f>(y, x) = cv::Point2f(f.u[p], f.v[p]);
    }
  return m;
}

sim::FlowField fromMat(const cv::Mat& flow) {
  sim::FlowField f;
  f.H = flow.rows;
  f.W = flow.cols;
  f.u.resize(static_cast<std::size_t>(f.H) * f.W);
  f.v.resize(f.u.size());
  for (int y = 0; y < f.H; ++y)
    for (int x = 0; x < f.W; ++x) {
      const cv::Point2f d = flow.at<cv::Point2f>(y, x);
      f.u[static_cast<std::size_t>(y) * f.W + x] = d.x;
      f.v[static_cast<std::size_t>(y) * f.W + x] = d.y;
    }
  return f;
}

class DisFlow final : public sim::FlowEstimator {
 public:
  // OpenCV 4.6's DIS takes no initial flow: `to` is warped by the initial flow, DIS finds the
  // residual r of `from` against it, and the flow is composed as r(x) + f0(x + r(x)).
  sim::FlowField compute(const sim::GrayImage& from, const sim::GrayImage& to,
                         const sim::FlowField& initial) const override {
    const cv::Mat f0 = toFlowMat(initial);
    cv::Mat map(f0.size(), CV_32FC2);
    for (int y = 0; y < f0.rows; ++y)
      for (int x = 0; x < f0.cols; ++x)
        map.at<cv::Point2f>(y, x) = f0.at<cv::Point2f>(y, x) + cv::Point2f(x, y);
    cv::Mat warped;
    cv::remap(toMat8(to), warped, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    // One instance per call: DISOpticalFlow keeps state between calc()s.
    cv::Ptr<cv::DISOpticalFlow> dis = cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_MEDIUM);
    cv::Mat r;
    dis->calc(toMat8(from), warped, r);
    cv::Mat flow(r.size(), CV_32FC2);
    for (int y = 0; y < r.rows; ++y)
      for (int x = 0; x < r.cols; ++x) {
        const cv::Point2f d = r.at<cv::Point2f>(y, x);
        const Eigen::Vector2d f = sim::sampleFlow(initial, x + d.x, y + d.y);
        flow.at<cv::Point2f>(y, x) =
            d + cv::Point2f(static_cast<float>(f.x()), static_cast<float>(f.y()));
      }
    return fromMat(flow);
  }
};

class FarnebackFlow final : public sim::FlowEstimator {
 public:
  sim::FlowField compute(const sim::GrayImage& from, const sim::GrayImage& to,
                         const sim::FlowField& initial) const override {
    cv::Mat flow = toFlowMat(initial);
    cv::calcOpticalFlowFarneback(toMat8(from), toMat8(to), flow, 0.5, 3, 15, 3, 5, 1.1,
                                 cv::OPTFLOW_USE_INITIAL_FLOW);
    return fromMat(flow);
  }
};

}  // namespace

void registerOpenCvFlow() {
  // Deterministic results: OpenCV's own thread pool would make DIS's summation order vary.
  cv::setNumThreads(0);
  sim::registerFlowEstimator("dis", [] { return std::make_unique<DisFlow>(); });
  sim::registerFlowEstimator("farneback", [] { return std::make_unique<FarnebackFlow>(); });
}

}  // namespace dbacov::flow
