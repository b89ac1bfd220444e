// Camera readers on their own: numbered files, image sequences read frame by
// frame and reopened, a malformed device spec.
#include "hullpipe/capture/camera_reader.h"

#include <sys/stat.h>

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

TEST(CameraReader, NumberedFileExpandsOneIntegerConversion) {
  EXPECT_EQ(NumberedFile("mask_%04d.png", 7), "mask_0007.png");
  EXPECT_EQ(NumberedFile("m%d.png", 12), "m12.png");
  EXPECT_EQ(NumberedFile("still.png", 3), "still.png");      // no conversion: one file for every frame
  EXPECT_EQ(NumberedFile("odd_%s.png", 3), "odd_%s.png");    // not a number: a literal name
  EXPECT_EQ(NumberedFile("wide_%012d.png", 3), "wide_%012d.png");  // over 9 digits: literal, not printf
}

TEST(CameraReader, AnImageSequenceIsReadInOrderAndReopened) {
  const auto dir = test::TempDir("camera_reader_seq");
  for (int k = 0; k < 3; ++k)
    cv::imwrite((dir / cv::format("f_%02d.png", k)).string(), cv::Mat(6, 8, CV_8UC3, cv::Scalar::all(10 * k)));
  const std::string pattern = (dir / "f_%02d.png").string();
  EXPECT_EQ(FirstFileNumber(pattern), 0);
  FileCameraReader reader(3, pattern);
  cv::Mat img;
  for (int k = 0; k < 3; ++k) {
    ASSERT_TRUE(reader.Read(&img)) << k;
    EXPECT_EQ(img.size(), cv::Size(8, 6));
    EXPECT_EQ(img.at<cv::Vec3b>(0, 0)[0], 10 * k);
  }
  EXPECT_FALSE(reader.Read(&img));  // the end
  reader.Reopen();
  ASSERT_TRUE(reader.Read(&img));
  EXPECT_EQ(img.at<cv::Vec3b>(0, 0)[0], 0);  // the first frame again
  // Frames of the calibrated size only.
  EXPECT_EQ(ReadCalibratedFrames(3, "frames", pattern, 10, 8, 6).size(), 3u);
  EXPECT_EQ(ReadCalibratedFrames(3, "frames", pattern, 10, 9, 6).size(), 0u);
}

// Every frame of an image sequence is checked from its header before OpenCV
// decodes any: a PNG whose header claims 20000x20000 px (OpenCV would allocate
// 1.2 GB for it), bytes of no image format, a frame of another size and a FIFO
// are each refused naming the file; the sequence before them reads (the control).
TEST(CameraReader, AnImageSequenceIsCheckedFromItsHeadersBeforeAnyDecode) {
  const auto dir = test::TempDir("camera_reader_hostile_seq");
  for (int k = 0; k < 2; ++k)
    cv::imwrite((dir / cv::format("f_%02d.png", k)).string(), cv::Mat(6, 8, CV_8UC3, cv::Scalar::all(10 * k)));
  const std::string pattern = (dir / "f_%02d.png").string();
  EXPECT_NO_THROW(CheckImageSequence(pattern));
  FileCameraReader good(3, pattern);
  cv::Mat img;
  EXPECT_TRUE(good.Read(&img));
  const auto expect_refused = [&](const std::string& what) {
    try {
      OpenCameraCapture(pattern);
      ADD_FAILURE() << "not refused: " << what;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("f_02.png"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  const std::string third = (dir / "f_02.png").string();
  {
    // The 8-byte signature and an IHDR chunk of 20000 x 20000, 8-bit RGB.
    std::vector<uint8_t> png = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A, 0, 0, 0, 13, 'I', 'H', 'D', 'R',
                                0,    0,   0x4E, 0x20, 0, 0, 0x4E, 0x20, 8, 2, 0, 0, 0, 0, 0, 0, 0};
    std::ofstream(third, std::ios::binary)
        .write(reinterpret_cast<const char*>(png.data()), std::streamsize(png.size()));
  }
  expect_refused("20000x20000");
  std::ofstream(third, std::ios::binary) << "not an image at all, just text";
  expect_refused("header");
  cv::imwrite(third, cv::Mat(7, 8, CV_8UC3, cv::Scalar::all(1)));
  expect_refused("first frame is 8x6");
  std::filesystem::remove(third);
  ASSERT_EQ(mkfifo(third.c_str(), 0600), 0);
  expect_refused("regular file");
  std::filesystem::remove(third);
  EXPECT_NO_THROW(OpenCameraCapture(pattern)) << "the sequence ends at its first gap again";
}

// A sequence named by its first file ("f_01.png" instead of "f_%02d.png") is
// the sequence from that number, checked as the pattern is: FFmpeg once opened
// such a file as one still frame, so the camera ended after frame 1 without a
// reason, and a bad later file was never checked. A name without digits is a
// single still image (the control for the count).
TEST(CameraReader, AnImageSequenceNamedByItsFirstFileIsTheSequenceChecked) {
  const auto dir = test::TempDir("camera_reader_first_file");
  for (int k = 0; k < 4; ++k)
    cv::imwrite((dir / cv::format("f_%02d.png", k)).string(), cv::Mat(6, 8, CV_8UC3, cv::Scalar::all(10 * k)));
  const std::string first = (dir / "f_01.png").string();
  const auto seq = FindImageSequence(first);
  ASSERT_TRUE(seq.has_value());
  EXPECT_EQ(seq->pattern, (dir / "f_%02d.png").string());
  EXPECT_EQ(seq->first, 1);
  EXPECT_EQ(seq->count, 3);
  FileCameraReader reader(1, first);
  EXPECT_EQ(reader.declared_frames(), 3);
  cv::Mat img;
  for (int k = 1; k < 4; ++k) {
    ASSERT_TRUE(reader.Read(&img)) << k;
    EXPECT_EQ(img.at<cv::Vec3b>(0, 0)[0], 10 * k);
  }
  EXPECT_FALSE(reader.Read(&img));
  EXPECT_TRUE(reader.error().empty()) << reader.error();  // the end, not a failure
  // Frames past file 1 (OpenCV's own sequences start at 0 or 1 only).
  EXPECT_EQ(FindImageSequence((dir / "f_03.png").string())->count, 1);
  // A later file whose header lies is refused naming it, before any decode.
  std::ofstream(dir / "f_02.png", std::ios::binary) << "not an image at all, just text";
  try {
    FileCameraReader bad(1, first);
    ADD_FAILURE() << "not refused";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("f_02.png"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("header"), std::string::npos) << e.what();
  }
  // A still without digits in its name: one frame. A video or a missing file
  // is no image sequence.
  cv::imwrite((dir / "still.png").string(), cv::Mat(6, 8, CV_8UC3, cv::Scalar::all(7)));
  EXPECT_EQ(FindImageSequence((dir / "still.png").string())->count, 1);
  EXPECT_FALSE(FindImageSequence((dir / "missing_00.png").string()).has_value());
  std::ofstream(dir / "clip_00.avi") << "RIFF";
  EXPECT_FALSE(FindImageSequence((dir / "clip_00.avi").string()).has_value());
  // A file that fails to decode after the check (replaced mid-run) ends the
  // reader with its reason, naming the file.
  cv::imwrite((dir / "f_02.png").string(), cv::Mat(6, 8, CV_8UC3, cv::Scalar::all(20)));
  FileCameraReader later(1, first);
  ASSERT_TRUE(later.Read(&img));
  {
    std::vector<uint8_t> png;
    cv::imencode(".png", cv::Mat(6, 8, CV_8UC3, cv::Scalar::all(1)), png);
    png.resize(png.size() / 2);  // the header intact, the data cut
    std::ofstream(dir / "f_02.png", std::ios::binary).write(reinterpret_cast<const char*>(png.data()),
                                                           std::streamsize(png.size()));
  }
  EXPECT_FALSE(later.Read(&img));
  EXPECT_NE(later.error().find("f_02.png"), std::string::npos) << later.error();
}

// (A file that does not open is a capture node test,
// CaptureFiles.AMissingVideoNamesTheCameraAndTheFile: OpenCV's probing of every
// backend for a missing file leaks inside libusb, which the sanitizer build of
// this test would report.)
TEST(CameraReader, AMalformedV4l2SpecIsRefused) {
  try {
    OpenCameraCapture("v4l2:x");
    ADD_FAILURE() << "opened";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("expected v4l2:<device index>"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace hullpipe
