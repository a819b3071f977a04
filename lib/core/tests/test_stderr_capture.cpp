// The one redirection of standard error (lib/core/include/fishcam/core/stderr_capture.hpp): captures say
// what was written in their scope, and however silencings and captures on different
// threads interleave, file descriptor 2 ends where it started.
#include <sys/stat.h>
#include <unistd.h>

#include <cstring>
#include <memory>
#include <thread>
#include <vector>

#include "fishcam/core/stderr_capture.hpp"
#include "fishcam/testing/test_support.hpp"

namespace fishcam {
namespace {

struct FileIdentity {
  dev_t device;
  ino_t inode;
  bool operator==(const FileIdentity&) const = default;
};

FileIdentity standard_error() {
  struct stat st {};
  EXPECT_EQ(fstat(STDERR_FILENO, &st), 0);
  return {st.st_dev, st.st_ino};
}

void say(const char* text) { (void)!write(STDERR_FILENO, text, std::strlen(text)); }

TEST(StderrCapture, SaysWhatItsScopeWrote) {
  const FileIdentity before = standard_error();
  std::string said;
  {
    detail::StderrCapture capture;
    say("first complaint\nsecond\n");
    said = capture.summary();
    EXPECT_TRUE(standard_error() == before) << "standard error is back after summary()";
  }
  EXPECT_EQ(said, "first complaint (2 lines)");
  {
    detail::StderrCapture capture;
    EXPECT_EQ(capture.summary(), "") << "a new capture starts empty";
  }
  EXPECT_TRUE(standard_error() == before);
}

// A capture that starts inside a silencing and ends before it, and the reverse: two
// independent redirections left fd 2 on the other's file in one of these orders.
TEST(StderrCapture, InterleavedScopesLeaveStandardErrorWhereItWas) {
  const FileIdentity before = standard_error();
  {
    auto silence = std::make_unique<detail::SilencedStderr>();
    detail::StderrCapture capture;
    say("inside both\n");
    silence.reset();
    EXPECT_EQ(capture.summary(), "inside both (1 line)");
  }
  EXPECT_TRUE(standard_error() == before);
  {
    auto capture = std::make_unique<detail::StderrCapture>();
    detail::SilencedStderr silence;
    capture.reset();
  }
  EXPECT_TRUE(standard_error() == before);
  // Many threads silencing while captures come and go.
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([t] {
      for (int i = 0; i < 200; ++i) {
        if ((i + t) % 3 == 0) {
          detail::StderrCapture capture;
          (void)capture.summary();
        } else {
          const detail::SilencedStderr silence;
        }
      }
    });
  }
  for (auto& thread : threads) thread.join();
  EXPECT_TRUE(standard_error() == before);
}

}  // namespace
}  // namespace fishcam
