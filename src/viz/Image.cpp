#include "viz/Image.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/Check.h"
#include "common/FileIo.h"

namespace vln::viz {

namespace {

void checkImage(const Image& image, const char* what) {
  VLN_CHECK_ARG(image.width > 0 && image.height > 0 &&
                    image.rgb.size() ==
                        static_cast<size_t>(image.width) * image.height * 3,
                what, ": image of ", image.width, "x", image.height, " holds ",
                image.rgb.size(), " bytes, expected width x height x 3");
}

cv::Mat bgrOf(const Image& image) {
  cv::Mat rgb(image.height, image.width, CV_8UC3,
              const_cast<uint8_t*>(image.rgb.data()));
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  return bgr;
}

std::string encode(const Image& image, const char* extension,
                   const std::vector<int>& params, const char* what) {
  checkImage(image, what);
  std::vector<uint8_t> bytes;
  VLN_CHECK_IO(cv::imencode(extension, bgrOf(image), bytes, params), what, ": ",
               extension, " encoding of a ", image.width, "x", image.height,
               " image failed");
  return std::string(bytes.begin(), bytes.end());
}

}  // namespace

std::string encodePng(const Image& image) {
  return encode(image, ".png", {}, "encodePng()");
}

Image decodePng(std::string_view bytes) {
  VLN_CHECK_IO(bytes.size() >= 8 && bytes.substr(0, 8) == "\x89PNG\r\n\x1a\n",
               "decodePng(): not a PNG signature (", bytes.size(), " bytes)");
  const cv::Mat raw(1, static_cast<int>(bytes.size()), CV_8UC1,
                    const_cast<char*>(bytes.data()));
  const cv::Mat bgr = cv::imdecode(raw, cv::IMREAD_COLOR);
  VLN_CHECK_IO(!bgr.empty(), "decodePng(): OpenCV cannot decode the ",
               bytes.size(), " bytes as PNG");
  Image out{bgr.cols, bgr.rows,
            std::vector<uint8_t>(static_cast<size_t>(bgr.cols) * bgr.rows * 3)};
  cv::Mat target(bgr.rows, bgr.cols, CV_8UC3, out.rgb.data());
  cv::cvtColor(bgr, target, cv::COLOR_BGR2RGB);
  return out;
}

std::string encodeJpeg(const Image& image, int quality) {
  VLN_CHECK_ARG(quality >= 1 && quality <= 100,
                "encodeJpeg(): quality must be in [1, 100], got ", quality);
  return encode(image, ".jpg", {cv::IMWRITE_JPEG_QUALITY, quality},
                "encodeJpeg()");
}

void savePng(const Image& image, const std::filesystem::path& file) {
  common::writeFileAtomic(file, encodePng(image));
}

Image resizeImage(const Image& image, int width, int height) {
  checkImage(image, "resizeImage()");
  VLN_CHECK_ARG(width > 0 && height > 0, "resizeImage(): target size ", width,
                "x", height, " must be positive");
  if (width == image.width && height == image.height) return image;
  cv::Mat source(image.height, image.width, CV_8UC3,
                 const_cast<uint8_t*>(image.rgb.data()));
  Image out{width, height,
            std::vector<uint8_t>(static_cast<size_t>(width) * height * 3)};
  cv::Mat target(height, width, CV_8UC3, out.rgb.data());
  const bool shrinking = width < image.width || height < image.height;
  cv::resize(source, target, cv::Size(width, height), 0, 0,
             shrinking ? cv::INTER_AREA : cv::INTER_NEAREST);
  return out;
}

}  // namespace vln::viz
