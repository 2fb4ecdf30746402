#pragma once
// Ranks: the processes of an MPI job (docs/scaling.md), as the tracers see them.
//
// veil runs as one process, or under `mpirun -np K` as K ranks that each run the same command
// on their own threads. A Ranks value names the group a piece of work is split over: world()
// (every rank of the job; rank 0 of 1 when veil was not started by mpirun) or alone() (this
// process by itself: the variants of a sweep split over the ranks, each traced by one). Work
// is split by index (Ranks::owns), every rank drawing the same counter-based random streams it
// would draw alone, and results travel to rank 0 as bytes and are added there in the order of
// one process: `mpirun -np K` gives bitwise the result of one process for any K.
//
// MPI is optional (built when CMake finds it, VEIL_MPI): without it world() is one rank, and
// a veil started by mpirun with more than one rank stops with a message (RankSession).
//
// Thread use: the calls below come from one thread at a time (MPI_THREAD_SERIALIZED), which
// the ordered consumers of tracer/ranked_blocks.h are.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace veil {

using Bytes = std::vector<std::byte>;

// Appends values to a byte buffer (trivially copyable values and vectors of them).
class ByteWriter {
  public:
    template <class T>
    void put(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        const auto* p = reinterpret_cast<const std::byte*>(&v);
        bytes_.insert(bytes_.end(), p, p + sizeof(T));
    }
    template <class T>
    void putVector(const std::vector<T>& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        put(static_cast<uint64_t>(v.size()));
        const auto* p = reinterpret_cast<const std::byte*>(v.data());
        bytes_.insert(bytes_.end(), p, p + v.size() * sizeof(T));
    }
    void putString(const std::string& s) {
        put(static_cast<uint64_t>(s.size()));
        const auto* p = reinterpret_cast<const std::byte*>(s.data());
        bytes_.insert(bytes_.end(), p, p + s.size());
    }
    Bytes take() { return std::move(bytes_); }

  private:
    Bytes bytes_;
};

// Reads back what a ByteWriter wrote, in the same order; std::runtime_error past the end.
class ByteReader {
  public:
    explicit ByteReader(const Bytes& bytes) : bytes_(bytes) {}
    template <class T>
    T get() {
        static_assert(std::is_trivially_copyable_v<T>);
        T v;
        std::memcpy(&v, take(sizeof(T)), sizeof(T));
        return v;
    }
    template <class T>
    std::vector<T> getVector() {
        static_assert(std::is_trivially_copyable_v<T>);
        const uint64_t n = get<uint64_t>();
        if (n > (bytes_.size() - at_) / std::max<size_t>(1, sizeof(T))) fail();
        std::vector<T> v(static_cast<size_t>(n));
        if (n) std::memcpy(v.data(), take(n * sizeof(T)), n * sizeof(T));
        return v;
    }
    std::string getString() {
        const uint64_t n = get<uint64_t>();
        if (n > bytes_.size() - at_) fail();
        const auto* p = reinterpret_cast<const char*>(take(n));
        return std::string(p, p + n);
    }
    bool done() const { return at_ == bytes_.size(); }

  private:
    const std::byte* take(size_t n) {
        if (n > bytes_.size() - at_) fail();
        const std::byte* p = bytes_.data() + at_;
        at_ += n;
        return p;
    }
    [[noreturn]] static void fail() {
        throw std::runtime_error("a message between ranks ended early (ranks out of step)");
    }
    const Bytes& bytes_;
    size_t at_ = 0;
};

class Ranks {
  public:
    // Every rank of the job (0 of 1 without mpirun).
    static Ranks world();
    // This process by itself.
    static Ranks alone() { return Ranks(0, 1); }

    int rank() const { return rank_; }
    int size() const { return size_; }
    bool root() const { return rank_ == 0; }
    bool single() const { return size_ == 1; }
    // Item i of a split by index: rank i mod size.
    bool owns(uint64_t i) const { return i % static_cast<uint64_t>(size_) == uint64_t(rank_); }
    // How many of the items 0 .. n - 1 this rank owns; its j-th is item j size + rank.
    uint64_t ownedCount(uint64_t n) const {
        const auto k = static_cast<uint64_t>(size_), r = static_cast<uint64_t>(rank_);
        return n > r ? (n - r + k - 1) / k : 0;
    }

    // Point to point, in order between a pair of ranks. post starts sending and returns,
    // keeping the bytes until MPI has taken them; once more than `pending` posted sends are
    // under way it waits for the oldest (a fast rank runs ahead of its receiver by at most
    // that many messages). waitPosted waits for all; send is post and waitPosted.
    void post(int to, Bytes data, size_t pending) const;
    void waitPosted() const;
    void send(int to, const Bytes& data) const;
    Bytes receive(int from) const;
    // Rank 0's bytes to every rank (others' `data` is replaced).
    void broadcast(Bytes& data) const;
    // Every rank's bytes on every rank, indexed by rank.
    std::vector<Bytes> gatherAll(const Bytes& mine) const;
    // Every rank's bytes on rank 0 (indexed by rank; empty elsewhere).
    std::vector<Bytes> gatherToRoot(const Bytes& mine) const;
    // Rank 0's flag on every rank.
    bool broadcastFlag(bool flag) const;
    // Waits for every rank.
    void barrier() const;

  private:
    Ranks(int rank, int size) : rank_(rank), size_(size) {}
    int rank_ = 0, size_ = 1;
};

// Bytes this process has sent to and received from other ranks so far (point to point,
// broadcasts and gathers; 0 in a single process), and the wall time it spent in those calls,
// waiting for the others included: what a run moved and what that cost (docs/scaling.md).
struct RankTraffic {
    uint64_t sent = 0, received = 0;
    double seconds = 0.0;
};
RankTraffic rankTraffic();

// Whether this veil was built with MPI.
bool mpiBuilt();

// The job's MPI lifetime, held by main(): starts MPI when veil was launched by mpirun (its
// environment says so) and ends it on destruction. A veil built without MPI that mpirun
// started as one of several ranks throws std::runtime_error (every rank would write the same
// files).
class RankSession {
  public:
    RankSession(int& argc, char**& argv);
    ~RankSession();
    RankSession(const RankSession&) = delete;
    RankSession& operator=(const RankSession&) = delete;
};

// This process's rank as the launcher's environment gives it (OpenMPI, PMIx, Hydra), known
// before MPI starts: 0 when not started by mpirun.
int launcherRank();

// Ends the whole job (every rank) with this exit code, after a failure on this rank.
[[noreturn]] void abortRanks(int code);

}  // namespace veil
