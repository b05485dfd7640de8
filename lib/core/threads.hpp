#pragma once
// How many threads to use (docs/cli.md#threads).
//   - The default is the CPUs this process may run on: its CPU affinity (taskset,
//     a batch scheduler's core binding) and its cgroup CPU quota (containers,
//     systemd, Slurm), whichever is smaller; OMP_NUM_THREADS, when set, wins.
//   - The thread governor adapts the team to a busy machine: 0.1 s after a team
//     is requested and then every half second it compares the busy time of
//     those CPUs (/proc/stat, without steal) with this process's own CPU time.
//     On an idle machine it uses the requested team. When other processes hold
//     some of the CPUs it measures the steps per second of a team that fits the
//     CPUs left free and of the full team (two windows of 0.2 s each, in the
//     order free, full, full, free), keeps the faster for
//     5 s, then measures again (the hold doubles, up to 40 s, while the same
//     team keeps winning). Results do not
//     depend on the number of threads, so this changes only the speed.
namespace swarmsim {

// CPUs this process may use: affinity, then the cgroup quota (at least 1)
int availableCpus();
// the default thread count (OMP_NUM_THREADS if set, else availableCpus())
int defaultThreadCount();
// process-wide: whether ThreadGovernors adapt (default true; --fixed-threads)
void setThreadAdaptation(bool on);
bool threadAdaptation();

// The process's thread team (one per process: it follows the machine across
// simulations, bench repetitions and thread counts).
// requestThreads(n): n threads on an idle machine (the team is set at once,
// fewer if the machine was last seen busy, and
// looked at again 0.1 s later); threadTick(): call between steps;
// cheap (a clock read), and every ~0.5 s a look at the machine.
void requestThreads(int n);
void threadTick();
// threads in use now
int threadsInUse();
// whether the governor has looked at the machine since the team was requested
// and is not measuring team sizes now (always true when it does not adapt):
// what `swarmsim bench` waits for before it times steps
bool threadsSettled();

}  // namespace swarmsim
