#include "hullpipe/util/image_file.h"

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

namespace hullpipe {
namespace {

namespace fs = std::filesystem;

cv::Mat Pattern(int w, int h) {
  cv::Mat img(h, w, CV_8UC3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) img.at<cv::Vec3b>(y, x) = cv::Vec3b(uint8_t(x * 7), uint8_t(y * 11), uint8_t(x ^ y));
  return img;
}

std::vector<uint8_t> Encode(const std::string& ext, const cv::Mat& img) {
  std::vector<uint8_t> bytes;
  EXPECT_TRUE(cv::imencode(ext, img, bytes)) << ext;
  return bytes;
}

fs::path TempDir() {
  const fs::path d = fs::temp_directory_path() / ("hullpipe_image_file_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

TEST(ImageFile, EveryFormatsHeaderGivesTheEncodersSize) {
  const cv::Mat img = Pattern(37, 23);
  for (const auto& [ext, format] : std::vector<std::pair<std::string, std::string>>{
           {".png", "png"}, {".jpg", "jpeg"}, {".bmp", "bmp"}, {".ppm", "pnm"}, {".pgm", "pnm"}, {".tiff", "tiff"}}) {
    cv::Mat src = img;
    if (ext == ".pgm") cv::extractChannel(img, src, 0);
    const std::vector<uint8_t> bytes = Encode(ext, src);
    const auto h = ParseImageHeader(bytes.data(), bytes.size());
    ASSERT_TRUE(h) << ext;
    EXPECT_EQ(h->format, format) << ext;
    EXPECT_EQ(h->width, 37) << ext;
    EXPECT_EQ(h->height, 23) << ext;
    std::string why;
    const cv::Mat back = DecodeImage(bytes.data(), bytes.size(), cv::IMREAD_UNCHANGED, &why);
    ASSERT_FALSE(back.empty()) << ext << ": " << why;
    EXPECT_EQ(back.size(), cv::Size(37, 23)) << ext;
  }
}

TEST(ImageFile, ABigEndianTiffAndABottomUpBmpAndACommentedPnm) {
  // TIFF "MM": one IFD with ImageWidth 640 (SHORT) and ImageLength 70000 (LONG).
  std::vector<uint8_t> tiff = {'M', 'M', 0, 42, 0, 0, 0, 8, 0, 2,
                               1, 0, 0, 3, 0, 0, 0, 1, 2, 128, 0, 0,
                               1, 1, 0, 4, 0, 0, 0, 1, 0, 1, 17, 112};
  auto h = ParseImageHeader(tiff.data(), tiff.size());
  ASSERT_TRUE(h);
  EXPECT_EQ(h->width, 640);
  EXPECT_EQ(h->height, 70000);
  const std::string pnm = "P6\n# made by hand\n 12  # width\n7\n255\n";
  h = ParseImageHeader(reinterpret_cast<const uint8_t*>(pnm.data()), pnm.size());
  ASSERT_TRUE(h);
  EXPECT_EQ(h->width, 12);
  EXPECT_EQ(h->height, 7);
  // Eleven digits is past any int: refused, not wrapped.
  const std::string huge = "P6 99999999999 7 255\n";
  EXPECT_FALSE(ParseImageHeader(reinterpret_cast<const uint8_t*>(huge.data()), huge.size()));
}

// A header that claims 20000x20000 is refused from the header: nothing of
// 1.2 GB is allocated (the decoder is never called), for PNG and JPEG alike.
TEST(ImageFile, AHeaderClaimingAHugeImageIsRefusedBeforeDecoding) {
  std::vector<uint8_t> png = Encode(".png", Pattern(16, 16));
  for (int i : {16, 20}) {  // IHDR width and height, big-endian
    png[size_t(i)] = 0, png[size_t(i) + 1] = 0, png[size_t(i) + 2] = 0x4e, png[size_t(i) + 3] = 0x20;
  }
  std::string why;
  EXPECT_TRUE(DecodeImage(png.data(), png.size(), cv::IMREAD_COLOR, &why).empty());
  EXPECT_NE(why.find("20000x20000"), std::string::npos) << why;
  EXPECT_NE(why.find("16384"), std::string::npos) << why;

  std::vector<uint8_t> jpg = Encode(".jpg", Pattern(16, 16));
  const auto h = ParseImageHeader(jpg.data(), jpg.size());
  ASSERT_TRUE(h);
  // Find the SOF0 marker and patch its height and width.
  for (size_t i = 2; i + 9 < jpg.size(); ++i)
    if (jpg[i] == 0xff && jpg[i + 1] == 0xc0) {
      jpg[i + 5] = 0x4e, jpg[i + 6] = 0x20, jpg[i + 7] = 0x4e, jpg[i + 8] = 0x20;
      break;
    }
  why.clear();
  EXPECT_TRUE(DecodeImage(jpg.data(), jpg.size(), cv::IMREAD_COLOR, &why).empty());
  EXPECT_NE(why.find("jpeg header says 20000x20000"), std::string::npos) << why;

  // The file's size is read from its header alone.
  const fs::path file = TempDir() / "huge.png";
  std::ofstream(file, std::ios::binary).write(reinterpret_cast<const char*>(png.data()), std::streamsize(png.size()));
  const auto probed = ProbeImageFile(file.string());
  ASSERT_TRUE(probed);
  EXPECT_EQ(probed->width, 20000);
  why.clear();
  EXPECT_TRUE(ReadImageFile(file.string(), cv::IMREAD_COLOR, &why).empty());
  EXPECT_EQ(why.rfind(file.string() + ": ", 0), 0u) << why;
}

// ProbeImageFile reads 64 KiB first and more only for the formats whose size
// may lie deeper: a JPEG with 200 KB of APP segments before its start of
// frame, and a PNM with 100 KB of comments before its size, are still probed;
// a file of another format is not (a video given as a camera's frames).
TEST(ImageFile, AHeaderPastTheFirst64KiBIsStillProbed) {
  const std::vector<uint8_t> jpg = Encode(".jpg", Pattern(40, 30));
  std::vector<uint8_t> deep(jpg.begin(), jpg.begin() + 2);  // SOI
  for (int k = 0; k < 4; ++k) {                              // APP1 segments of 50,000 bytes
    deep.insert(deep.end(), {0xff, 0xe1, uint8_t(50000 >> 8), uint8_t(50000 & 0xff)});
    deep.insert(deep.end(), 50000 - 2, uint8_t('x'));
  }
  deep.insert(deep.end(), jpg.begin() + 2, jpg.end());
  std::string pnm = "P6\n";
  for (int k = 0; k < 2000; ++k) pnm += "# a comment of fifty bytes, padded out to fifty.\n";
  pnm += "40 30\n255\n" + std::string(40 * 30 * 3, '\x10');
  const fs::path dir = TempDir();
  std::ofstream(dir / "deep.jpg", std::ios::binary).write(reinterpret_cast<const char*>(deep.data()),
                                                          std::streamsize(deep.size()));
  std::ofstream(dir / "deep.ppm", std::ios::binary) << pnm;
  for (const char* name : {"deep.jpg", "deep.ppm"}) {
    const auto h = ProbeImageFile((dir / name).string());
    ASSERT_TRUE(h) << name;
    EXPECT_EQ(h->width, 40) << name;
    EXPECT_EQ(h->height, 30) << name;
  }
  std::ofstream(dir / "clip.avi", std::ios::binary) << "RIFF" << std::string(200000, '\0');
  EXPECT_FALSE(ProbeImageFile((dir / "clip.avi").string()));
}

// Bytes of a format hullpipe does not read never reach OpenCV: a DICOM file
// (a 128-byte preamble and "DICM"), which OpenCV would hand to GDCM, whose
// parser aborts on malformed elements.
TEST(ImageFile, AFormatHullpipeDoesNotReadNeverReachesADecoder) {
  std::vector<uint8_t> dicom(128, 0);
  for (char c : std::string("DICM\x02\x00\x00\x00UL\x04\x00\xff\xff\xff\x7f", 16)) dicom.push_back(uint8_t(c));
  dicom.resize(400, 0xd9);
  EXPECT_FALSE(ParseImageHeader(dicom.data(), dicom.size()));
  std::string why;
  EXPECT_TRUE(DecodeImage(dicom.data(), dicom.size(), cv::IMREAD_COLOR, &why).empty());
  EXPECT_NE(why.find("not a PNG, JPEG"), std::string::npos) << why;
  EXPECT_FALSE(ParseImageHeader(nullptr, 0));
}

// Every cut of every format: the parser reads only what it was given (ASan
// checks), and a cut image is refused or decoded, never more.
TEST(ImageFile, EveryCutOfEveryFormatIsParsedWithinItsBytes) {
  for (const std::string ext : {".png", ".jpg", ".bmp", ".ppm", ".tiff"}) {
    const std::vector<uint8_t> bytes = Encode(ext, Pattern(9, 5));
    for (size_t n = 0; n < bytes.size(); ++n) {
      const std::vector<uint8_t> cut(bytes.begin(), bytes.begin() + std::ptrdiff_t(n));
      const auto h = ParseImageHeader(cut.data(), cut.size());
      if (h) {
        EXPECT_EQ(h->width, 9) << ext << " cut at " << n;
      }
      std::string why;
      const cv::Mat img = DecodeImage(cut.data(), cut.size(), cv::IMREAD_COLOR, &why);
      if (!img.empty()) {
        EXPECT_EQ(img.size(), cv::Size(9, 5)) << ext << " cut at " << n;
      }
    }
  }
}

// A FIFO would block open() until a writer comes: refused, at once.
TEST(ImageFile, AFifoIsRefusedWithoutOpeningIt) {
  const fs::path fifo = TempDir() / "frames.png";
  fs::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string why;
  EXPECT_TRUE(ReadImageFile(fifo.string(), cv::IMREAD_COLOR, &why).empty());
  EXPECT_NE(why.find("not a regular file"), std::string::npos) << why;
  EXPECT_FALSE(ProbeImageFile(fifo.string()));
  EXPECT_FALSE(ProbeImageFile((TempDir() / "absent.png").string()));
  fs::remove_all(TempDir());
}

}  // namespace
}  // namespace hullpipe
