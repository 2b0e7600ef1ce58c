#include "cli/interrupt.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

namespace machplan::cli {

namespace {
StopSource g_stop;
constexpr int kSignals[3] = {SIGINT, SIGTERM, SIGHUP};
extern "C" void on_stop_signal(int) { g_stop.request_stop(); }
double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

StopOnSignals::StopOnSignals() {
  g_stop.reset();
  struct sigaction sa = {};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  for (int i = 0; i < 3; ++i) sigaction(kSignals[i], &sa, &old_[i]);
}

StopOnSignals::~StopOnSignals() {
  for (int i = 0; i < 3; ++i) sigaction(kSignals[i], &old_[i], nullptr);
}

StopToken StopOnSignals::stop_token() { return g_stop.token(); }

ProgressBar::ProgressBar(std::string label, bool wanted)
    : label_(std::move(label)), on_(wanted && isatty(STDERR_FILENO)), start_s_(now_s()) {}

ProgressBar::~ProgressBar() { done(); }

void ProgressBar::done() {
  if (drawn_) std::fprintf(stderr, "\r%*s\r", drawn_width_, "");
  drawn_ = on_ = false;
}

void ProgressBar::update(double fraction, const std::string& detail) {
  if (!on_) return;
  const double t = now_s();
  // Quiet for the first second (short work shows nothing), then at most ten redraws a second.
  if (t - start_s_ < 1.0 || (last_s_ >= 0 && t - last_s_ < 0.1)) return;
  last_s_ = t;
  const double f = std::isfinite(fraction) ? std::clamp(fraction, 0.0, 1.0) : 0.0;
  const int width = 30, full = static_cast<int>(f * width);
  const int w = std::fprintf(stderr, "\r%s [%.*s%*s] %3.0f %% %s", label_.c_str(), full, "##############################",
                             width - full, "", 100 * f, detail.c_str());
  if (w - 1 < drawn_width_) std::fprintf(stderr, "%*s", drawn_width_ - (w - 1), "");  // what the last line had more
  drawn_width_ = std::max(drawn_width_, w - 1);
  std::fflush(stderr);
  drawn_ = true;
}

ProgressWatch::ProgressWatch(std::string label, bool wanted, const Progress& progress, std::function<std::string()> detail)
    : bar_(std::move(label), wanted), read_([&progress] { return progress.share(); }), detail_(std::move(detail)), clear_at_one_(true) {
  start();
}

void ProgressWatch::start() {
  if (!bar_.drawing()) return;  // nothing to draw: no thread
  thread_ = std::thread([this] {
    while (!over_.load()) {
      const double share = read_();
      if (clear_at_one_ && share >= 1.0) {
        bar_.done();
        return;
      }
      bar_.update(share, detail_ ? detail_() : std::string());
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  });
}

ProgressWatch::~ProgressWatch() {
  over_ = true;
  if (thread_.joinable()) thread_.join();
  bar_.done();
}

}  // namespace machplan::cli
