// A small process pool for `fsp bench`: runs commands as child processes, at most N at a time,
// each with its stdout and stderr in a log file, a job starting only after the job it depends on
// succeeded. Among the jobs that may start, the one with the longest remaining chain of cost
// (its own cost plus that of the costliest chain of jobs depending on it) starts first, so long
// runs do not end up alone at the end.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace fsp::apps {

struct Job {
  std::vector<std::string> argv;  // argv[0]: the program (a path; PATH is not searched)
  std::string log;                // stdout and stderr (created, truncated)
  int after = -1;                 // index of the job this one needs to succeed first (-1: none)
  double cost = 1.0;              // expected duration, any unit: only the order depends on it
};

struct JobResult {
  bool started = false;  // false: its dependency failed, or the program could not be started
  int exit_code = -1;    // 0 on success; 128 + signal when killed by a signal
  double wall_s = 0.0;
  bool ok() const { return started && exit_code == 0; }
};

// Runs JOBS (at most MAX_PARALLEL at a time, >= 1) and returns their results in the same order.
// ON_DONE (optional) is called in the calling thread after each job ends, with its index, while
// other jobs keep running. Throws InputError when a dependency index is out of range or not
// earlier in the list.
std::vector<JobResult> RunJobs(const std::vector<Job>& jobs, int max_parallel,
                               const std::function<void(size_t, const JobResult&)>& on_done = {});

// The running program's own executable (/proc/self/exe), for spawning its subcommands.
std::string SelfExecutable();

// The last non-empty line of a log file (a child's error message), "" when none.
std::string LastLine(const std::string& path);

}  // namespace fsp::apps
