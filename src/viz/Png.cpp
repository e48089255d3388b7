#include "viz/Png.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <vector>

#include "common/Check.h"

namespace vln::viz {

std::string encodePng(std::span<const uint8_t> pixels, int width, int height,
                      int channels) {
  VLN_CHECK_ARG(channels == 1 || channels == 3 || channels == 4,
                "encodePng(): channels must be 1, 3 or 4, got ", channels);
  VLN_CHECK_ARG(
      width > 0 && height > 0 &&
          pixels.size() == static_cast<size_t>(width) * height * channels,
      "encodePng(): expected ", width, "x", height, "x", channels,
      " bytes, got ", pixels.size());
  // OpenCV writes BGR(A) in the order its Mat holds
  const cv::Mat image(height, width, CV_8UC(channels),
                      const_cast<uint8_t*>(pixels.data()));
  // converted into a Mat of its own: the caller's pixels are const
  cv::Mat ordered;
  if (channels == 3) {
    cv::cvtColor(image, ordered, cv::COLOR_RGB2BGR);
  } else if (channels == 4) {
    cv::cvtColor(image, ordered, cv::COLOR_RGBA2BGRA);
  } else {
    ordered = image;
  }
  std::vector<uint8_t> png;
  VLN_CHECK_IO(cv::imencode(".png", ordered, png),
               "encodePng(): OpenCV cannot encode a ", width, "x", height, "x",
               channels, " image as PNG");
  return std::string(png.begin(), png.end());
}

DecodedImage decodePng(std::string_view bytes) {
  VLN_CHECK_IO(bytes.size() >= 8 && bytes.substr(0, 8) == "\x89PNG\r\n\x1a\n",
               "decodePng(): not a PNG signature (", bytes.size(), " bytes)");
  const cv::Mat raw(1, static_cast<int>(bytes.size()), CV_8UC1,
                    const_cast<char*>(bytes.data()));
  const cv::Mat image = cv::imdecode(raw, cv::IMREAD_UNCHANGED);
  VLN_CHECK_IO(!image.empty() && image.depth() == CV_8U,
               "decodePng(): OpenCV cannot decode the ", bytes.size(),
               " bytes as an 8-bit PNG");
  DecodedImage out;
  out.width = image.cols;
  out.height = image.rows;
  out.channels = image.channels();
  cv::Mat ordered;
  if (out.channels == 3) {
    cv::cvtColor(image, ordered, cv::COLOR_BGR2RGB);
  } else if (out.channels == 4) {
    cv::cvtColor(image, ordered, cv::COLOR_BGRA2RGBA);
  } else {
    ordered = image;
  }
  const cv::Mat packed = ordered.isContinuous() ? ordered : ordered.clone();
  out.pixels.assign(packed.data,
                    packed.data + packed.total() * packed.elemSize());
  return out;
}

}  // namespace vln::viz
