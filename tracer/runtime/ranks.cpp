#include "tracer/runtime/ranks.h"

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <deque>
#include <string>

#ifdef VEIL_MPI
#include <mpi.h>
#endif

namespace veil {

namespace {

// The job's size from the launcher's environment (OpenMPI, PMIx, Hydra): 0 when none says.
int launcherSize() {
    for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_SIZE", "PMI_SIZE"})
        if (const char* v = std::getenv(name)) return std::atoi(v);
    return 0;
}

}  // namespace

int launcherRank() {
    for (const char* name : {"OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"})
        if (const char* v = std::getenv(name)) return std::atoi(v);
    return 0;
}

namespace {

bool started = false;  // MPI_Init ran in this process
int worldRank = 0, worldSize = 1;
// Calls come from one thread at a time (MPI_THREAD_SERIALIZED); atomics let any thread read.
std::atomic<uint64_t> bytesSent{0}, bytesReceived{0};
std::atomic<int64_t> nanosecondsInCalls{0};

// Adds the wall time of its scope to nanosecondsInCalls.
struct CallClock {
    std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
    ~CallClock() {
        nanosecondsInCalls += std::chrono::duration_cast<std::chrono::nanoseconds>(
                                  std::chrono::steady_clock::now() - start)
                                  .count();
    }
};

}  // namespace

bool mpiBuilt() {
#ifdef VEIL_MPI
    return true;
#else
    return false;
#endif
}

Ranks Ranks::world() { return Ranks(worldRank, worldSize); }

RankTraffic rankTraffic() {
    return {bytesSent.load(), bytesReceived.load(),
            1e-9 * static_cast<double>(nanosecondsInCalls.load())};
}

RankSession::RankSession(int& argc, char**& argv) {
    const int size = launcherSize();
    if (size == 0 && !std::getenv("PMIX_RANK")) return;  // not started by mpirun
#ifdef VEIL_MPI
    int provided = 0;
    if (MPI_Init_thread(&argc, &argv, MPI_THREAD_SERIALIZED, &provided) != MPI_SUCCESS)
        throw std::runtime_error("MPI could not start");
    started = true;
    MPI_Comm_rank(MPI_COMM_WORLD, &worldRank);
    MPI_Comm_size(MPI_COMM_WORLD, &worldSize);
    if (provided < MPI_THREAD_SERIALIZED && worldSize > 1)
        throw std::runtime_error(
            "this MPI library does not let threads take turns calling it "
            "(MPI_THREAD_SERIALIZED), which veil's ranks need");
#else
    (void)argc;
    (void)argv;
    if (size > 1)
        throw std::runtime_error(
            "started by mpirun as one of " + std::to_string(size) +
            " ranks, but this veil was built without MPI (install Debian's libopenmpi-dev and "
            "build again; docs/scaling.md): every rank would trace the whole run and write the "
            "same files");
#endif
}

RankSession::~RankSession() {
#ifdef VEIL_MPI
    if (started) MPI_Finalize();
#endif
}

void abortRanks(int code) {
#ifdef VEIL_MPI
    if (started && worldSize > 1) MPI_Abort(MPI_COMM_WORLD, code);
#endif
    std::exit(code);
}

#ifdef VEIL_MPI

namespace {

// MPI counts are ints: messages go in pieces of at most 1 GiB.
constexpr size_t kPiece = size_t{1} << 30;
constexpr int kTag = 7;

void check(int rc, const char* what) {
    if (rc != MPI_SUCCESS) throw std::runtime_error(std::string("MPI: ") + what + " failed");
}

void broadcastFrom(int root, Bytes& data) {
    const CallClock clock;
    uint64_t n = data.size();
    check(MPI_Bcast(&n, 1, MPI_UINT64_T, root, MPI_COMM_WORLD), "broadcast");
    data.resize(static_cast<size_t>(n));
    (worldRank == root ? bytesSent : bytesReceived) +=
        worldRank == root ? n * static_cast<uint64_t>(worldSize - 1) : n;
    for (size_t at = 0; at < n; at += kPiece)
        check(MPI_Bcast(data.data() + at, static_cast<int>(std::min<size_t>(kPiece, n - at)),
                        MPI_BYTE, root, MPI_COMM_WORLD),
              "broadcast");
}

}  // namespace

namespace {

// Sends under way (Ranks::post): their buffers live until MPI has taken them.
struct Posted {
    uint64_t size = 0;
    Bytes data;
    std::vector<MPI_Request> requests;
};
std::deque<Posted> posted;

void waitOldest() {
    Posted& p = posted.front();
    check(MPI_Waitall(static_cast<int>(p.requests.size()), p.requests.data(), MPI_STATUSES_IGNORE),
          "send");
    posted.pop_front();
}

}  // namespace

void Ranks::post(int to, Bytes data, size_t pending) const {
    const CallClock clock;
    bytesSent += data.size();
    Posted& p = posted.emplace_back();
    p.size = data.size();
    p.data = std::move(data);
    // The size, then the bytes in pieces (MPI counts are ints); one pair of ranks keeps its
    // messages in order, so the receiver reads them as they were posted.
    p.requests.emplace_back();
    check(MPI_Isend(&p.size, 1, MPI_UINT64_T, to, kTag, MPI_COMM_WORLD, &p.requests.back()),
          "send");
    for (size_t at = 0; at < p.size; at += kPiece) {
        p.requests.emplace_back();
        check(MPI_Isend(p.data.data() + at, static_cast<int>(std::min<size_t>(kPiece, p.size - at)),
                        MPI_BYTE, to, kTag, MPI_COMM_WORLD, &p.requests.back()),
              "send");
    }
    while (posted.size() > pending) waitOldest();
}

void Ranks::waitPosted() const {
    const CallClock clock;
    while (!posted.empty()) waitOldest();
}

void Ranks::send(int to, const Bytes& data) const { post(to, data, 0); }

Bytes Ranks::receive(int from) const {
    const CallClock clock;
    uint64_t n = 0;
    check(MPI_Recv(&n, 1, MPI_UINT64_T, from, kTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE), "receive");
    Bytes data(static_cast<size_t>(n));
    bytesReceived += n;
    for (size_t at = 0; at < n; at += kPiece)
        check(MPI_Recv(data.data() + at, static_cast<int>(std::min<size_t>(kPiece, n - at)),
                       MPI_BYTE, from, kTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE),
              "receive");
    return data;
}

void Ranks::broadcast(Bytes& data) const {
    if (size_ > 1) broadcastFrom(0, data);
}

std::vector<Bytes> Ranks::gatherAll(const Bytes& mine) const {
    std::vector<Bytes> all(static_cast<size_t>(size_));
    for (int r = 0; r < size_; ++r) {
        if (r == rank_) all[static_cast<size_t>(r)] = mine;
        if (size_ > 1) broadcastFrom(r, all[static_cast<size_t>(r)]);
    }
    return all;
}

std::vector<Bytes> Ranks::gatherToRoot(const Bytes& mine) const {
    std::vector<Bytes> all;
    if (!root()) {
        send(0, mine);
        return all;
    }
    all.resize(static_cast<size_t>(size_));
    all[0] = mine;
    for (int r = 1; r < size_; ++r) all[static_cast<size_t>(r)] = receive(r);
    return all;
}

bool Ranks::broadcastFlag(bool flag) const {
    if (size_ == 1) return flag;
    const CallClock clock;
    int v = flag ? 1 : 0;
    check(MPI_Bcast(&v, 1, MPI_INT, 0, MPI_COMM_WORLD), "broadcast");
    return v != 0;
}

void Ranks::barrier() const {
    if (size_ > 1) check(MPI_Barrier(MPI_COMM_WORLD), "barrier");
}

#else  // without MPI every group is this process alone

namespace {
[[noreturn]] void noPeers() {
    throw std::logic_error("veil was built without MPI: there is no other rank to talk to");
}
}  // namespace

void Ranks::post(int, Bytes, size_t) const { noPeers(); }
void Ranks::waitPosted() const {}
void Ranks::send(int, const Bytes&) const { noPeers(); }
Bytes Ranks::receive(int) const { noPeers(); }
void Ranks::broadcast(Bytes&) const {}
std::vector<Bytes> Ranks::gatherAll(const Bytes& mine) const { return {mine}; }
std::vector<Bytes> Ranks::gatherToRoot(const Bytes& mine) const { return {mine}; }
bool Ranks::broadcastFlag(bool flag) const { return flag; }
void Ranks::barrier() const {}

#endif

}  // namespace veil
