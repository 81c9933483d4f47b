#include "renderer/app/mpi_group.h"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <stdexcept>

#if TESSERA_MPI
#include <mpi.h>
#endif

namespace tessera {

bool launched_by_mpi() {
    for (const char *v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE", "PMI_RANK"})
        if (std::getenv(v))
            return true;
    return false;
}

#if TESSERA_MPI

bool mpi_built_in() { return true; }

std::string mpi_build_info() {
    char v[MPI_MAX_LIBRARY_VERSION_STRING];
    int n = 0;
    MPI_Get_library_version(v, &n);
    std::string s(v, size_t(std::max(0, n)));
    // "Open MPI v4.1.4, package: ..." -> "Open MPI v4.1.4".
    if (size_t comma = s.find(','); comma != std::string::npos)
        s.resize(comma);
    while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
    return "MPI: " + s + " (built in; used under mpirun)";
}

namespace {

void check(int rc, const char *what) {
    if (rc != MPI_SUCCESS) {
        char msg[MPI_MAX_ERROR_STRING];
        int n = 0;
        MPI_Error_string(rc, msg, &n);
        throw std::runtime_error(std::string(what) + ": " + std::string(msg, size_t(n)));
    }
}

/// The scheduler's collectives over a communicator (see scheduler/rank_group.h).
class MpiRankGroup final : public sched::RankGroup {
  public:
    explicit MpiRankGroup(MPI_Comm comm) : comm_(comm) {
        int r = 0, s = 1;
        MPI_Comm_rank(comm_, &r);
        MPI_Comm_size(comm_, &s);
        rank_ = uint32_t(r);
        size_ = uint32_t(s);
    }
    uint32_t rank() const override { return rank_; }
    uint32_t size() const override { return size_; }

    void sum(std::span<double> values) override {
        const auto t0 = std::chrono::steady_clock::now();
        check(MPI_Allreduce(MPI_IN_PLACE, values.data(), int(values.size()), MPI_DOUBLE, MPI_SUM,
                            comm_),
              "MPI_Allreduce");
        add_comm(t0);
    }
    void min(std::span<uint64_t> values) override {
        const auto t0 = std::chrono::steady_clock::now();
        check(MPI_Allreduce(MPI_IN_PLACE, values.data(), int(values.size()), MPI_UINT64_T,
                            MPI_MIN, comm_),
              "MPI_Allreduce");
        add_comm(t0);
    }
    void all_gather(std::span<const double> mine, std::span<const size_t> counts,
                    std::span<double> all) override {
        const auto t0 = std::chrono::steady_clock::now();
        std::vector<int> n(size_), off(size_);
        size_t total = 0;
        for (uint32_t r = 0; r < size_; ++r) {
            n[r] = int(counts[r]);
            off[r] = int(total);
            total += counts[r];
        }
        if (total > all.size() || counts[rank_] != mine.size())
            throw std::invalid_argument("MpiRankGroup::all_gather: counts do not match");
        check(MPI_Allgatherv(mine.data(), int(mine.size()), MPI_DOUBLE, all.data(), n.data(),
                             off.data(), MPI_DOUBLE, comm_),
              "MPI_Allgatherv");
        add_comm(t0);
    }
    std::vector<std::vector<std::byte>> gather_to_root(std::span<const std::byte> mine) override {
        const auto t0 = std::chrono::steady_clock::now();
        // Sizes first, then the bytes (in pieces of at most 1 GiB: MPI counts are ints).
        const uint64_t my_size = mine.size();
        std::vector<uint64_t> sizes(size_);
        check(MPI_Gather(&my_size, 1, MPI_UINT64_T, sizes.data(), 1, MPI_UINT64_T, 0, comm_),
              "MPI_Gather");
        std::vector<std::vector<std::byte>> pieces;
        constexpr uint64_t kChunk = uint64_t(1) << 30;
        if (rank_ == 0) {
            pieces.resize(size_);
            pieces[0].assign(mine.begin(), mine.end());
            for (uint32_t r = 1; r < size_; ++r) {
                pieces[r].resize(sizes[r]);
                for (uint64_t o = 0; o < sizes[r]; o += kChunk)
                    check(MPI_Recv(pieces[r].data() + o, int(std::min(kChunk, sizes[r] - o)),
                                   MPI_BYTE, int(r), 7, comm_, MPI_STATUS_IGNORE),
                          "MPI_Recv");
            }
        } else {
            for (uint64_t o = 0; o < my_size; o += kChunk)
                check(MPI_Send(mine.data() + o, int(std::min(kChunk, my_size - o)), MPI_BYTE, 0,
                               7, comm_),
                      "MPI_Send");
        }
        add_comm(t0);
        return pieces;
    }
    bool decide(bool flag) override {
        const auto t0 = std::chrono::steady_clock::now();
        int v = flag ? 1 : 0;
        check(MPI_Bcast(&v, 1, MPI_INT, 0, comm_), "MPI_Bcast");
        add_comm(t0);
        return v != 0;
    }
    void barrier() override {
        const auto t0 = std::chrono::steady_clock::now();
        check(MPI_Barrier(comm_), "MPI_Barrier");
        add_comm(t0);
    }
    void arrive() override {
        const auto t0 = std::chrono::steady_clock::now();
        check(MPI_Barrier(comm_), "MPI_Barrier");
        add_wait(t0);
    }

  private:
    MPI_Comm comm_;
    uint32_t rank_ = 0, size_ = 1;
};

}  // namespace

struct MpiJob::Impl {
    std::unique_ptr<MpiRankGroup> group;
};

MpiJob::MpiJob() : impl_(std::make_unique<Impl>()) {}

std::unique_ptr<MpiJob> MpiJob::start(int &argc, char **&argv) {
    if (!launched_by_mpi())
        return nullptr;
    int provided = 0;
    check(MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
    // Errors come back as codes (check() turns them into exceptions) instead of aborting
    // inside MPI without a word.
    MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
    std::unique_ptr<MpiJob> job(new MpiJob());
    job->impl_->group = std::make_unique<MpiRankGroup>(MPI_COMM_WORLD);
    if (provided < MPI_THREAD_FUNNELED)
        throw std::runtime_error("MPI_Init_thread: the MPI library does not provide "
                                 "MPI_THREAD_FUNNELED");
    return job;
}

MpiJob::~MpiJob() {
    int finalized = 0;
    MPI_Finalized(&finalized);
    if (!finalized)
        MPI_Finalize();
}

uint32_t MpiJob::rank() const { return impl_->group->rank(); }
uint32_t MpiJob::size() const { return impl_->group->size(); }
sched::RankGroup &MpiJob::group() { return *impl_->group; }
void MpiJob::abort(int code) {
    MPI_Abort(MPI_COMM_WORLD, code);
    std::_Exit(code);
}
std::string MpiJob::host() const {
    char name[MPI_MAX_PROCESSOR_NAME];
    int n = 0;
    MPI_Get_processor_name(name, &n);
    return std::string(name, size_t(std::max(0, n)));
}

#else  // no MPI in this build

namespace {

// The job size the launcher announced (1 when it says nothing).
int launcher_size() {
    for (const char *v : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"})
        if (const char *s = std::getenv(v))
            return std::max(1, std::atoi(s));
    return 1;
}

}  // namespace

bool mpi_built_in() { return false; }

std::string mpi_build_info() { return "MPI: not built in (TESSERA_MPI=OFF)"; }

struct MpiJob::Impl {};

MpiJob::MpiJob() = default;

std::unique_ptr<MpiJob> MpiJob::start(int &, char **&) {
    if (launched_by_mpi() && launcher_size() > 1)
        throw std::runtime_error(
            "this tessera was built without MPI (TESSERA_MPI=OFF: install libopenmpi-dev and "
            "rebuild); under mpirun each of the " + std::to_string(launcher_size()) +
            " ranks would render the whole image alone");
    return nullptr;
}

MpiJob::~MpiJob() = default;
uint32_t MpiJob::rank() const { return 0; }
uint32_t MpiJob::size() const { return 1; }
sched::RankGroup &MpiJob::group() { throw std::logic_error("MpiJob: no MPI in this build"); }
void MpiJob::abort(int code) { std::_Exit(code); }
std::string MpiJob::host() const { return ""; }

#endif

}  // namespace tessera
