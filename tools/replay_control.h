// hullpipe_replay's controls beside the player (record/player.h): the keyboard
// on a terminal and the RecordCommand topic (hullpipe_cmd pause|resume|step|
// seek|rate), both writing into the player's PlayerControl, and the stop on
// SIGINT/SIGTERM.
#pragma once

#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <thread>

#include <spdlog/spdlog.h>

#include "hullpipe/dds/dds.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/record/player.h"

namespace hullpipe::record {

// Raw keyboard input for pause/step/quit while stdin is a terminal; restores
// the terminal on destruction.
class Keyboard {
 public:
  Keyboard(PlayerControl* control, double rate) : control_(control), rate_(rate > 0 ? rate : 1) {
    if (!isatty(STDIN_FILENO)) return;
    tcgetattr(STDIN_FILENO, &saved_);
    termios raw = saved_;
    raw.c_lflag &= tcflag_t(~(ICANON | ECHO));
    raw.c_cc[VMIN] = 0;
    raw.c_cc[VTIME] = 1;  // reads return after 0.1 s
    tcsetattr(STDIN_FILENO, TCSANOW, &raw);
    active_ = true;
    thread_ = std::thread([this] {
      while (!control_->stop.load() && !done_.load()) {
        char c = 0;
        if (read(STDIN_FILENO, &c, 1) != 1) continue;
        if (c == ' ') {
          control_->paused = !control_->paused.load();
          std::fprintf(stderr, control_->paused ? "[paused: space resumes, s steps]\n" : "[playing]\n");
        } else if (c == 's') {
          ++control_->steps;
        } else if (c == ']' || c == '[') {
          rate_ = std::clamp(c == ']' ? rate_ * 2 : rate_ / 2, PlayerOptions::kMinRate, PlayerOptions::kMaxRate);
          control_->new_rate = rate_;
          std::fprintf(stderr, "[rate %g]\n", rate_);
        } else if (c == '0') {
          control_->seek_s = 0;
          std::fprintf(stderr, "[from the start]\n");
        } else if (c == ',' || c == '.') {
          const double to = std::max(0.0, control_->position_s.load() + (c == '.' ? 5.0 : -5.0));
          control_->seek_s = to;
          std::fprintf(stderr, "[seek %.1f s]\n", to);
        } else if (c == 'q') {
          control_->stop = true;
        }
      }
    });
  }
  ~Keyboard() {
    done_ = true;
    if (thread_.joinable()) thread_.join();
    if (active_) tcsetattr(STDIN_FILENO, TCSANOW, &saved_);
  }

 private:
  PlayerControl* control_;
  double rate_;
  termios saved_{};
  bool active_ = false;
  std::atomic<bool> done_{false};
  std::thread thread_;
};

// Sets `stop` on SIGINT/SIGTERM and applies RecordCommands from the domain
// (pause, resume, step, seek, rate); sets `stop` and joins on scope exit, also
// when an exception leaves main's body.
class Steering {
 public:
  Steering(PlayerControl* control, const dds::Participant& participant)
      : control_(control), commands_(participant), thread_([this] {
          while (!control_->stop.load()) {
            if (dds::StopRequested()) control_->stop = true;
            commands_.TakeEach([&](const hullpipe_msg_RecordCommand& c, const dds_sample_info_t&) { Apply(c); });
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
          }
        }) {}
  ~Steering() {
    control_->stop = true;
    thread_.join();
  }
  int64_t ignored() const { return ignored_; }

 private:
  void Apply(const hullpipe_msg_RecordCommand& c) {
    switch (c.command) {
      case hullpipe_msg_RECORD_COMMAND_PAUSE: control_->paused = true; break;
      case hullpipe_msg_RECORD_COMMAND_RESUME: control_->paused = false; break;
      case hullpipe_msg_RECORD_COMMAND_STEP:
        if (c.value >= 1 && c.value <= 1e6) control_->steps += int(c.value);
        else return Ignore(c, "step count out of [1, 1e6]");
        break;
      case hullpipe_msg_RECORD_COMMAND_SEEK:
        if (c.value >= 0 && c.value <= PlayerOptions::kMaxStartOffsetS) control_->seek_s = c.value;
        else return Ignore(c, "seek out of [0, 1e6] s");
        break;
      case hullpipe_msg_RECORD_COMMAND_RATE:
        if (c.value == 0 || (c.value >= PlayerOptions::kMinRate && c.value <= PlayerOptions::kMaxRate))
          control_->new_rate = c.value;
        else return Ignore(c, "rate not 0 or in [0.001, 1000]");
        break;
      case hullpipe_msg_RECORD_COMMAND_SNAPSHOT: return;  // the recorder's
      default: return Ignore(c, "unknown command");
    }
    spdlog::info("command {} (value {}) applied", int(c.command), c.value);
  }
  void Ignore(const hullpipe_msg_RecordCommand& c, const char* why) {
    ++ignored_;
    spdlog::warn("RecordCommand {} (command {}, value {}) ignored: {}", c.command_seq, int(c.command), c.value, why);
  }
  PlayerControl* control_;
  dds::Reader<hullpipe_msg_RecordCommand> commands_;
  std::atomic<int64_t> ignored_{0};
  std::thread thread_;
};

}  // namespace hullpipe::record
