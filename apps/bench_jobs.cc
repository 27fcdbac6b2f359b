#include "bench_jobs.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>

#include "fsp/common/error.h"

extern char** environ;  // NOLINT: POSIX

namespace fsp::apps {

namespace {

using Clock = std::chrono::steady_clock;

// Starts JOB; returns its pid, or -1 when it could not be started (the reason in its log).
pid_t Spawn(const Job& job) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, job.log.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  std::vector<char*> argv;
  for (const std::string& a : job.argv) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int err = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (err != 0) {
    std::ofstream log(job.log, std::ios::app);
    log << "cannot start " << job.argv[0] << ": " << std::strerror(err) << "\n";
    return -1;
  }
  return pid;
}

}  // namespace

std::vector<JobResult> RunJobs(const std::vector<Job>& jobs, int max_parallel,
                               const std::function<void(size_t, const JobResult&)>& on_done) {
  const size_t n = jobs.size();
  for (size_t i = 0; i < n; ++i) {
    if (jobs[i].after >= static_cast<int>(i) || jobs[i].after < -1)
      throw InputError("job " + std::to_string(i) + ": its dependency must be an earlier job");
  }
  // Priority: own cost plus the costliest chain of jobs that depend on it (dependents come later
  // in the list, so one backward pass suffices).
  std::vector<double> chain(n, 0.0);
  for (size_t k = n; k-- > 0;) {
    chain[k] += jobs[k].cost;
    if (jobs[k].after >= 0) {
      double& parent = chain[static_cast<size_t>(jobs[k].after)];
      parent = std::max(parent, chain[k]);
    }
  }
  std::vector<JobResult> results(n);
  enum class State { kWaiting, kRunning, kDone };
  std::vector<State> state(n, State::kWaiting);
  std::map<pid_t, std::pair<size_t, Clock::time_point>> running;
  const size_t parallel = static_cast<size_t>(std::max(1, max_parallel));
  size_t done = 0;
  const auto finish = [&](size_t i) {
    state[i] = State::kDone;
    ++done;
    if (on_done) on_done(i, results[i]);
  };
  while (done < n) {
    // Start what may start, the longest chain first.
    while (running.size() < parallel) {
      int best = -1;
      for (size_t i = 0; i < n; ++i) {
        if (state[i] != State::kWaiting) continue;
        const int a = jobs[i].after;
        if (a >= 0 && state[static_cast<size_t>(a)] != State::kDone) continue;
        if (a >= 0 && !results[static_cast<size_t>(a)].ok()) {
          finish(i);  // its dependency failed: never started
          continue;
        }
        if (best < 0 || chain[i] > chain[static_cast<size_t>(best)]) best = static_cast<int>(i);
      }
      if (best < 0) break;
      const size_t i = static_cast<size_t>(best);
      const pid_t pid = Spawn(jobs[i]);
      if (pid < 0) {
        finish(i);
        continue;
      }
      results[i].started = true;
      state[i] = State::kRunning;
      running[pid] = {i, Clock::now()};
    }
    if (running.empty()) continue;  // everything left was settled above
    int status = 0;
    const pid_t pid = waitpid(-1, &status, 0);
    if (pid < 0) {
      if (errno == EINTR) continue;
      throw InputError(std::string("waiting for the benchmark's processes: ") +
                       std::strerror(errno));
    }
    const auto it = running.find(pid);
    if (it == running.end()) continue;  // not one of ours
    const size_t i = it->second.first;
    results[i].wall_s = std::chrono::duration<double>(Clock::now() - it->second.second).count();
    results[i].exit_code = WIFEXITED(status)     ? WEXITSTATUS(status)
                           : WIFSIGNALED(status) ? 128 + WTERMSIG(status)
                                                 : -1;
    running.erase(it);
    finish(i);
  }
  return results;
}

std::string SelfExecutable() {
  std::error_code ec;
  const std::filesystem::path p = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) throw InputError("cannot find the fsp executable (/proc/self/exe): " + ec.message());
  return p.string();
}

std::string LastLine(const std::string& path) {
  std::ifstream in(path);
  std::string line, last;
  while (std::getline(in, line)) {
    // A progress bar rewrites its line with '\r': keep what follows the last one.
    const size_t cr = line.rfind('\r');
    if (cr != std::string::npos) line = line.substr(cr + 1);
    if (line.find_first_not_of(" \t") != std::string::npos) last = line;
  }
  return last;
}

}  // namespace fsp::apps
