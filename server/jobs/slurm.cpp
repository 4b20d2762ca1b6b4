#include "jobs/slurm.h"

#include <algorithm>
#include <charconv>
#include <set>
#include <sstream>

#include "dembuf/study/spawn/program.h"

namespace dembuf::server::slurm {

namespace {

std::optional<std::int64_t> ParseId(std::string_view text) {
  std::int64_t id = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), id);
  if (error != std::errc() || end != text.data() + text.size() || id <= 0) return std::nullopt;
  return id;
}

std::vector<std::string_view> Split(std::string_view text, char separator) {
  std::vector<std::string_view> parts;
  for (std::size_t start = 0;;) {
    const std::size_t end = text.find(separator, start);
    parts.push_back(text.substr(start, end == std::string_view::npos ? end : end - start));
    if (end == std::string_view::npos) return parts;
    start = end + 1;
  }
}

// A word of Slurm's: states and reasons are short upper-case words; anything else in their
// place is not taken at its word.
bool IsWord(std::string_view text) {
  return !text.empty() && text.size() <= 64 && std::all_of(text.begin(), text.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '+' || c == '-' ||
           c == ':' || c == ',' || c == '(' || c == ')' || c == '.';
  });
}

std::optional<int> Number(std::string_view text) {
  int value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || value < 0 || text.size() > 6)
    return std::nullopt;
  return value;
}

}  // namespace

bool IsFinalState(std::string_view state) {
  for (std::string_view final : {"COMPLETED", "FAILED", "CANCELLED", "TIMEOUT", "OUT_OF_MEMORY",
                                 "NODE_FAIL", "PREEMPTED", "BOOT_FAIL", "DEADLINE"})
    if (state == final) return true;
  return false;
}

Liveness LivenessOf(const JobStatus& job) {
  if (IsFinalState(job.state)) return Liveness::kEnded;
  if (job.state == "COMPLETING" || job.reason == "DependencyNeverSatisfied")
    return Liveness::kEnding;
  return Liveness::kMayRun;
}

const JobStatus* ChooseCopy(const std::vector<JobStatus>& jobs,
                            const std::function<bool(const JobStatus&)>& matches, Liveness least) {
  const JobStatus* chosen = nullptr;
  for (const JobStatus& job : jobs)
    if (matches(job) && LivenessOf(job) >= least && (!chosen || job.id > chosen->id)) chosen = &job;
  return chosen;
}

std::vector<JobKey> OtherLiveCopies(const std::vector<JobStatus>& jobs,
                                    const std::function<bool(const JobStatus&)>& matches,
                                    const JobStatus& chosen) {
  std::vector<JobKey> others;
  for (const JobStatus& job : jobs) {
    const JobKey key{job.id, job.task};
    if (key == JobKey{chosen.id, chosen.task} || !matches(job) ||
        LivenessOf(job) != Liveness::kMayRun ||
        std::find(others.begin(), others.end(), key) != others.end())
      continue;
    if (others.size() == kMaxOtherCopies) break;
    others.push_back(key);
  }
  return others;
}

namespace {

// An array task's index as squeue or scontrol print it; -1 for "N/A" (not an array's task),
// nothing for anything else.
std::optional<int> ParseTask(std::string_view text) {
  if (text == "N/A") return -1;
  const std::optional<int> task = Number(text);
  if (!task) return std::nullopt;
  return task;
}

}  // namespace

std::vector<JobStatus> ParseSqueue(std::string_view output) {
  std::vector<JobStatus> jobs;
  for (std::string_view line : Split(output, '\n')) {
    const std::vector<std::string_view> fields = Split(line, '|');
    if (fields.size() != 6) continue;
    const std::optional<std::int64_t> id = ParseId(fields[0]);
    const std::optional<int> task = ParseTask(fields[1]);
    if (!id || !task || !IsWord(fields[3]) || fields[2].size() > 256 || fields[4].size() > 256 ||
        fields[5].size() > 256)
      continue;
    jobs.push_back({*id, *task, std::string(fields[2]), std::string(fields[3]),
                    std::string(fields[4]), std::string(fields[5])});
  }
  return jobs;
}

std::vector<JobStatus> ParseScontrolJob(std::string_view line) {
  JobStatus job;
  std::int64_t array_id = 0;
  std::string tasks;
  std::istringstream words{std::string(line)};
  for (std::string word; words >> word;) {
    const std::size_t equals = word.find('=');
    if (equals == std::string::npos) continue;
    const std::string key = word.substr(0, equals), value = word.substr(equals + 1);
    if (key == "JobId") {
      if (const auto id = ParseId(value)) job.id = *id;
    } else if (key == "ArrayJobId") {
      if (const auto id = ParseId(value)) array_id = *id;
    } else if (key == "ArrayTaskId") {
      tasks = value;
    } else if (key == "JobName" && value.size() <= 256) {
      job.name = value;
    } else if (key == "JobState" && IsWord(value)) {
      job.state = value;
    } else if (key == "Reason" && value.size() <= 256) {
      job.reason = value;
    } else if (key == "NodeList" && value.size() <= 256 && value != "(null)") {
      job.node = value;
    }
  }
  if (job.id == 0 || job.state.empty()) return {};
  if (array_id == 0 && tasks.empty()) return {job};
  // A task of an array: known by the array's id and its index.
  const std::optional<std::vector<int>> indexes = ParseArrayIndexes(tasks);
  if (array_id == 0 || !indexes) return {};
  std::vector<JobStatus> each;
  for (int index : *indexes) {
    each.push_back(job);
    each.back().id = array_id;
    each.back().task = index;
  }
  return each;
}

std::string FormatArrayIndexes(std::vector<int> indexes) {
  std::sort(indexes.begin(), indexes.end());
  indexes.erase(std::unique(indexes.begin(), indexes.end()), indexes.end());
  std::string text;
  for (std::size_t i = 0; i < indexes.size();) {
    std::size_t last = i;
    while (last + 1 < indexes.size() && indexes[last + 1] == indexes[last] + 1) ++last;
    if (!text.empty()) text += ',';
    text += std::to_string(indexes[i]);
    if (last > i) text += '-' + std::to_string(indexes[last]);
    i = last + 1;
  }
  return text;
}

std::optional<std::vector<int>> ParseArrayIndexes(std::string_view text, std::size_t most) {
  text = text.substr(0, text.find('%'));
  if (text.empty() || text.size() > 4096) return std::nullopt;
  std::vector<int> indexes;
  for (std::string_view part : Split(text, ',')) {
    // "a", "a-b" or "a-b:step"
    const std::size_t colon = part.find(':');
    const std::optional<int> step =
        colon == std::string_view::npos ? std::optional<int>(1) : Number(part.substr(colon + 1));
    part = part.substr(0, colon);
    const std::size_t dash = part.find('-');
    const std::optional<int> first = Number(part.substr(0, dash));
    const std::optional<int> last =
        dash == std::string_view::npos ? first : Number(part.substr(dash + 1));
    if (!first || !last || !step || *step < 1 || *last < *first ||
        static_cast<std::size_t>((*last - *first) / *step) + indexes.size() >= most)
      return std::nullopt;
    for (int index = *first; index <= *last; index += *step) indexes.push_back(index);
  }
  return indexes;
}

std::optional<std::int64_t> ParseSbatchId(std::string_view output) {
  while (!output.empty() && (output.back() == '\n' || output.back() == ' '))
    output.remove_suffix(1);
  // The id is the last line (sbatch may warn first) and may name a cluster: "123;cluster".
  const std::size_t line = output.rfind('\n');
  if (line != std::string_view::npos) output.remove_prefix(line + 1);
  return ParseId(output.substr(0, output.find(';')));
}

std::optional<int> ParseTimeLimit(std::string_view text) {
  if (text.empty() || text.size() > 16) return std::nullopt;
  int days = 0;
  std::string_view rest = text;
  const bool has_days = text.find('-') != std::string_view::npos;
  if (has_days) {
    const auto d = Number(text.substr(0, text.find('-')));
    if (!d) return std::nullopt;
    days = *d;
    rest = text.substr(text.find('-') + 1);
  }
  const std::vector<std::string_view> parts = Split(rest, ':');
  std::vector<int> values;
  for (std::string_view part : parts) {
    const auto v = Number(part);
    if (!v) return std::nullopt;
    values.push_back(*v);
  }
  long seconds = 0;
  if (has_days) {  // D-HH, D-HH:MM, D-HH:MM:SS
    if (values.size() > 3) return std::nullopt;
    const int h = values[0], m = values.size() > 1 ? values[1] : 0,
              s = values.size() > 2 ? values[2] : 0;
    seconds = ((days * 24L + h) * 60L + m) * 60L + s;
  } else if (values.size() == 1) {  // MM
    seconds = values[0] * 60L;
  } else if (values.size() == 2) {  // MM:SS
    seconds = values[0] * 60L + values[1];
  } else if (values.size() == 3) {  // HH:MM:SS
    seconds = (values[0] * 60L + values[1]) * 60L + values[2];
  } else {
    return std::nullopt;
  }
  if (seconds <= 0 || seconds > 365L * 86400) return std::nullopt;
  return static_cast<int>(seconds);
}

std::string FormatTimeLimit(int seconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%d:%02d", seconds / 60, seconds % 60);
  return text;
}

std::vector<std::string> SbatchArgs(const Settings& settings, const Submission& job) {
  std::vector<std::string> args = {"sbatch",
                                   "--parsable",
                                   "--job-name=" + job.name,
                                   "--chdir=" + job.folder,
                                   "--output=" + job.log,
                                   "--cpus-per-task=" + std::to_string(job.cpus)};
  if (job.mem_mb > 0) args.push_back("--mem=" + std::to_string(job.mem_mb) + "M");
  if (job.time_s > 0) args.push_back("--time=" + FormatTimeLimit(job.time_s));
  if (!settings.partition.empty()) args.push_back("--partition=" + settings.partition);
  const std::string& account = job.account.empty() ? settings.account : job.account;
  if (!account.empty()) args.push_back("--account=" + account);
  if (!job.wckey.empty()) args.push_back("--wckey=" + job.wckey);
  if (!job.comment.empty()) args.push_back("--comment=" + job.comment);
  if (!job.array_tasks.empty())
    args.push_back("--array=" + FormatArrayIndexes(job.array_tasks) +
                   (job.array_limit > 0 ? "%" + std::to_string(job.array_limit) : ""));
  if (!job.after_ok.empty()) {
    std::string after = "afterok";
    for (std::int64_t id : job.after_ok) {
      after += ':';
      after += std::to_string(id);
    }
    args.push_back("--dependency=" + after);
    // A job whose bed failed is ended by Slurm instead of waiting for ever.
    args.push_back("--kill-on-invalid-dep=yes");
  }
  args.insert(args.end(), settings.extra_args.begin(), settings.extra_args.end());
  // The job gets sbatch's environment, the variables of the submission among it
  // (SubmitEnvironment).
  if (!job.environment.empty()) args.push_back("--export=ALL");
  std::string line = "exec";
  if (!job.array_tasks.empty())
    line = "job=$((" + std::to_string(job.array_base) + " + SLURM_ARRAY_TASK_ID)) && exec";
  for (const std::string& word : job.command) {
    line += ' ';
    if (job.array_tasks.empty()) {
      line += ShellQuote(word);
      continue;
    }
    // Each part quoted, and the task's job id, a number the shell computed, between them.
    std::string_view rest = word;
    for (std::size_t at; (at = rest.find(kTaskJobId)) != std::string_view::npos;) {
      line += ShellQuote(rest.substr(0, at)) + "\"$job\"";
      rest.remove_prefix(at + kTaskJobId.size());
    }
    line += ShellQuote(rest);
  }
  args.push_back("--wrap=" + line);
  return args;
}

namespace {

// What sbatch and squeue print when slurmctld is down or unknown, or the program cannot run.
bool SaysUnreachable(const std::string& error) {
  static const char* const signs[] = {"Unable to contact slurm controller",
                                      "Socket timed out",
                                      "Connection refused",
                                      "Zero Bytes were transmitted",
                                      "Communication connection failure",
                                      "unable to status file",
                                      "Could not establish a configuration source",
                                      "did not answer in",
                                      "cannot run",
                                      "No such file or directory"};
  for (const char* sign : signs)
    if (error.find(sign) != std::string::npos) return true;
  return false;
}

}  // namespace

bool SlurmUnreachable(const std::string& error) {
  return SaysUnreachable(error) || error.find("submission failed") == std::string::npos;
}

std::string Client::Run(const std::vector<std::string>& args, bool check,
                        const std::vector<std::string>& environment) {
  const ProgramResult result =
      RunProgram(args, std::chrono::seconds(m_settings.command_timeout_s), environment);
  if (result.timed_out)
    throw SlurmError(args[0] + " did not answer in " +
                     std::to_string(m_settings.command_timeout_s) + " s");
  if (result.overflowed)
    throw SlurmError(args[0] + " did not answer: it printed more than " +
                     std::to_string(kMaxProgramOutput >> 20) + " MiB");
  if (check && result.exit_code != 0)
    throw SlurmError(args[0] + " failed (exit " + std::to_string(result.exit_code) +
                     "): " + result.output.substr(0, 2000));
  return result.output;
}

std::vector<std::string> SubmitEnvironment(const Submission& job) {
  std::vector<std::string> environment;
  for (const auto& [name, value] : job.environment) {
    if (name.empty() || name.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZ_") != std::string::npos)
      throw SlurmError("not an environment variable's name: " + name.substr(0, 40));
    environment.push_back(name + "=" + value);
  }
  return environment;
}

std::int64_t Client::Submit(const Submission& job) {
  const std::string output = Run(SbatchArgs(m_settings, job), true, SubmitEnvironment(job));
  const std::optional<std::int64_t> id = ParseSbatchId(output);
  if (!id) throw SlurmError("sbatch did not print a job id: " + output.substr(0, 2000));
  return *id;
}

std::map<JobKey, JobStatus> Client::Query(const std::vector<std::int64_t>& ids) {
  std::map<JobKey, JobStatus> found;
  if (ids.empty()) return found;
  std::string list;
  for (std::int64_t id : ids) {
    if (!list.empty()) list += ',';
    list += std::to_string(id);
  }
  const ProgramResult squeue =
      RunProgram({"squeue", "-h", "-r", "-t", "all", "-j", list, "-o", kSqueueFormat},
                 std::chrono::seconds(m_settings.command_timeout_s));
  // Slurm that cannot be reached says nothing of the jobs: they are not taken as gone.
  if (squeue.exit_code == 127 || squeue.timed_out || squeue.overflowed ||
      (squeue.exit_code != 0 && SaysUnreachable(squeue.output)))
    throw SlurmError("squeue: " + (squeue.timed_out || squeue.overflowed
                                       ? std::string("no answer")
                                       : squeue.output.substr(0, 2000)));
  // (squeue refuses the whole list when one id is unknown to it: scontrol asks one by one.)
  std::set<std::int64_t> listed;
  for (const JobStatus& job : ParseSqueue(squeue.output))
    if (std::find(ids.begin(), ids.end(), job.id) != ids.end()) {
      found[{job.id, job.task}] = job;
      listed.insert(job.id);
    }
  for (std::int64_t id : ids) {
    if (listed.count(id)) continue;
    // (SLURM_BITSTR_LEN=0: an array's task list whole, not cut to 64 characters with "...")
    const ProgramResult scontrol =
        RunProgram({"scontrol", "show", "job", "-o", std::to_string(id)},
                   std::chrono::seconds(m_settings.command_timeout_s), {"SLURM_BITSTR_LEN=0"});
    if (scontrol.timed_out || scontrol.overflowed)
      throw SlurmError("scontrol show job " + std::to_string(id) + ": no answer");
    if (scontrol.exit_code != 0) {
      // Only Slurm's own word that it does not know the job makes it gone.
      if (scontrol.output.find("Invalid job id") != std::string::npos) continue;
      throw SlurmError("scontrol show job " + std::to_string(id) + " failed (exit " +
                       std::to_string(scontrol.exit_code) +
                       "): " + scontrol.output.substr(0, 2000));
    }
    listed.insert(id);  // (asked once, however often it is in `ids`)
    bool parsed = false;
    for (std::string_view line : Split(scontrol.output, '\n'))
      for (const JobStatus& job : ParseScontrolJob(line))
        if (job.id == id) {
          found[{job.id, job.task}] = job;
          parsed = true;
        }
    // An answer that cannot be read is asked again, not taken to say the job has gone.
    if (!parsed && scontrol.output.find("JobId=") != std::string::npos)
      throw SlurmError("scontrol show job " + std::to_string(id) +
                       " said what cannot be read: " + scontrol.output.substr(0, 500));
  }
  return found;
}

std::vector<JobStatus> Client::FindByNamePrefix(const std::string& prefix) {
  std::vector<JobStatus> jobs;
  for (const JobStatus& job :
       ParseSqueue(Run({"squeue", "-h", "-r", "--me", "-t", "all", "-o", kSqueueFormat})))
    if (job.name.rfind(prefix, 0) == 0) jobs.push_back(job);
  return jobs;
}

void Client::Cancel(std::int64_t id, int task) {
  Run({"scancel", std::to_string(id) + (task >= 0 ? "_" + std::to_string(task) : "")}, false);
}

}  // namespace dembuf::server::slurm
