// dgv: the launcher of dgv-core, the executable beside it that does the work.
//
// dgv-core links the GL stack (libOSMesa pulls in libLLVM), which the dynamic loader takes about
// 90 ms to relocate before any of dgv's own code runs; a SIGINT, SIGTERM or SIGHUP then (a farm
// cancelling a task as it starts) had its default action: exit 143 and no line. This launcher is
// linked statically and starts in well under a millisecond: it blocks those signals, which exec
// keeps blocked, and execs dgv-core, whose first code (app/main.cpp, installSignalHandlers, run
// from the pre-initialisation array) installs the handlers and unblocks them. A signal sent at any
// time after the launcher's first instruction is taken by the handler: one line, exit 130.

#include <cerrno>
#include <climits>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <unistd.h>

int main(int argc, char** argv) {
    (void)argc;
    sigset_t stops;
    sigemptyset(&stops);
    sigaddset(&stops, SIGINT);
    sigaddset(&stops, SIGTERM);
    sigaddset(&stops, SIGHUP);
    sigprocmask(SIG_BLOCK, &stops, nullptr);
    static const char kCore[] = "dgv-core";
    char path[PATH_MAX + sizeof kCore];
    const ssize_t n = readlink("/proc/self/exe", path, PATH_MAX);
    if (n <= 0) {
        std::fprintf(stderr, "dgv: error: cannot find this executable's folder (/proc/self/exe): %s\n",
                     std::strerror(errno));
        return 1;
    }
    path[n] = '\0';
    char* slash = std::strrchr(path, '/');
    std::memcpy(slash ? slash + 1 : path, kCore, sizeof kCore);
    execv(path, argv);
    std::fprintf(stderr, "dgv: error: cannot run %s: %s (build it with the dgv target)\n", path, std::strerror(errno));
    return 1;
}
