// OpenCV's dense optical flow as FlowEstimators of the simulator's image-based test bed
// (dbacov/sim/image_flow.h).
//   dis        cv::DISOpticalFlow, PRESET_MEDIUM (Kroeger et al. 2016): patch-based inverse
//              search with variational refinement, the fast dense flow of OpenCV's video module;
//   farneback  cv::calcOpticalFlowFarneback (polynomial expansion), 3 levels, window 15.
// Both refine the initial flow they are given: Farneback natively (OPTFLOW_USE_INITIAL_FLOW), DIS
// (which takes none in OpenCV 4.6) on the second image warped by it, composed afterwards.
// Images are converted to 8 bits (OpenCV's flows take CV_8UC1).
#pragma once

namespace dbacov::flow {

/// Registers "dis" and "farneback" with sim::registerFlowEstimator. Idempotent.
void registerOpenCvFlow();

}  // namespace dbacov::flow
