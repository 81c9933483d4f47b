// MPI for distributed renders (docs/ARCHITECTURE.md, "Distributed rendering"): the process's
// place in an `mpirun` job and the scheduler's RankGroup over MPI_COMM_WORLD.
//
// MPI starts only when the process was launched by an MPI launcher (mpirun / mpiexec set
// OMPI_COMM_WORLD_SIZE, PMIX_RANK or PMI_SIZE in each rank's environment); a `tessera` started
// by hand never initialises MPI and behaves exactly as a build without it. The MPI build is the
// CMake option TESSERA_MPI (on when the MPI package is found); without it every function here
// still exists: launched_by_mpi() then still tells, and start() refuses a job of several ranks
// (each would render the whole image alone).
// Thread level MPI_THREAD_FUNNELED: only the thread that calls AdaptiveScheduler::render
// (the main thread) communicates; the TBB workers never do.
#pragma once

#include <memory>
#include <string>

#include "scheduler/rank_group.h"

namespace tessera {

/// True when an MPI launcher started this process (see the file comment).
bool launched_by_mpi();

/// "MPI: Open MPI v4.1.4 (built in)" or "MPI: not built in (TESSERA_MPI=OFF)".
std::string mpi_build_info();
/// True when this binary was built with MPI.
bool mpi_built_in();

/// The MPI job of this process: MPI_Init_thread on construction (start()), MPI_Finalize on
/// destruction. One per process.
class MpiJob {
  public:
    /// Initialises MPI when launched_by_mpi(), else returns null. Throws std::runtime_error
    /// for a job of several ranks in a build without MPI.
    static std::unique_ptr<MpiJob> start(int &argc, char **&argv);
    ~MpiJob();
    MpiJob(const MpiJob &) = delete;
    MpiJob &operator=(const MpiJob &) = delete;

    uint32_t rank() const;
    uint32_t size() const;
    /// The group over MPI_COMM_WORLD (the scheduler's collectives).
    sched::RankGroup &group();
    /// Ends every rank of the job with `code` (MPI_Abort; mpirun reports which rank
    /// aborted). Used when one rank fails while the others may wait in a collective.
    [[noreturn]] void abort(int code);
    /// This rank's host name (MPI_Get_processor_name).
    std::string host() const;

  private:
    MpiJob();
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace tessera
