// The progress bar of the apps: its line, and that it appears only on a terminal and not with
// --quiet (standard error is swapped for a pseudo-terminal or /dev/null here).
#include <fcntl.h>
#include <stdlib.h>
#include <unistd.h>

#include <chrono>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>

#include "dbacov/app/progress.h"

namespace dbacov {
namespace {

using app::Progress;

TEST(Progress, LineShowsBarCountPercentTimeAndEstimate) {
  EXPECT_EQ(Progress::formatLine(12, 24, 3.2, "snap_12.npz", 200),
            "[##########..........]  12/24  50%  3 s, ~3 s left  snap_12.npz");
  EXPECT_EQ(Progress::formatLine(0, 4, 0.1, "a", 200), "[....................]  0/4  0%  0 s  a");
  EXPECT_EQ(Progress::formatLine(4, 4, 125, "a", 200),
            "[####################]  4/4  100%  2 min 05 s  a");
  EXPECT_EQ(Progress::formatLine(1, 3, 4000, "a", 200),
            "[######..............]  1/3  33%  1 h 06 min, ~2 h 13 min left  a");
  EXPECT_EQ(Progress::formatLine(7, 0, 2, "x.rawlog#7", 200), "7 done  2 s  x.rawlog#7");
  EXPECT_EQ(Progress::formatLine(12, 24, 3, "a-very-long-label", 30),
            "[##########..........]  12/24 ");
}

/// Runs `body` with file descriptor 2 replaced by `fd`.
template <class F>
void withStderr(int fd, F body) {
  const int saved = ::dup(2);
  ::dup2(fd, 2);
  body();
  ::dup2(saved, 2);
  ::close(saved);
}

/// What an enabled and a disabled (--quiet) progress display write with `stderr_fd` as fd 2.
std::pair<std::string, std::string> draw(int stderr_fd) {
  std::ostringstream on, off;
  withStderr(stderr_fd, [&] {
    Progress p(on, 3, true), q(off, 3, false);
    p.step("first");  // within the first half second: never drawn
    q.step("first");
    std::this_thread::sleep_for(std::chrono::milliseconds(550));
    p.step("second");
    q.step("second");
  });
  return {on.str(), off.str()};
}

TEST(Progress, DrawnOnlyOnATerminalAndWhenEnabled) {
  const int master = ::posix_openpt(O_RDWR | O_NOCTTY);
  ASSERT_GE(master, 0);
  ASSERT_EQ(::grantpt(master), 0);
  ASSERT_EQ(::unlockpt(master), 0);
  const int tty = ::open(::ptsname(master), O_RDWR | O_NOCTTY);
  ASSERT_GE(tty, 0);
  const auto [shown, quiet] = draw(tty);
  EXPECT_EQ(shown.rfind("\r\033[K[######..............]  1/3  33%", 0), 0u) << shown;
  EXPECT_NE(shown.find("second"), std::string::npos);
  EXPECT_EQ(shown.find("first"), std::string::npos) << "nothing in the first half second";
  EXPECT_EQ(shown.substr(shown.size() - 4), "\r\033[K") << "the line is cleared at the end";
  EXPECT_EQ(quiet, "") << "--quiet";
  ::close(tty);
  ::close(master);
  const int null = ::open("/dev/null", O_WRONLY);
  EXPECT_EQ(draw(null).first, "") << "not a terminal";
  ::close(null);
}

}  // namespace
}  // namespace dbacov
