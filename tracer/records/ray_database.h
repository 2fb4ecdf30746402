#pragma once
// The ray database: a file of complete path histories (every branch of every stored ray, with
// its geometry) written while tracing and read back to re-run analyses (criteria, detector
// images, path pictures) without tracing again. The format is in docs/ray-database.md.
//
//   header   magic "VEILRAYS", version, flags (what each event stores), seed, scene hash and
//            name, units, and the name tables: objects (with kind, part, property, aliases),
//            media, sources, scatter models; CRC-32
//   chunks   "VCHK" blocks of records in increasing ray index, each with a CRC-32 of its
//            payload; a record is a ray index delta and one encoded PathHistory
//   index    "VIDX": offset, first ray and record count of every chunk
//   end      "VEND": the index offset and the totals (emitted and stored rays, events, paths)
//
// Writing is thread-safe and deterministic: add() encodes into a per-thread buffer without
// locking; full buffers are handed to one ordered stream that writes records strictly in ray
// order, so the file's bytes depend only on which rays were added with which histories, never
// on the thread count or the order of the calls. The file is written under `<path>.partial`
// and renamed to `<path>` by close(); a writer destroyed without close() removes it.
//
// Reading checks every checksum and bound: a truncated or corrupt file throws a
// RayDatabaseError naming the file and the byte offset of the block (or byte) at fault.

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "geometry/scene.h"
#include "tracer/records/path_history.h"

namespace veil {

// Ray Database Header Data

// An object as criteria know it: names and globs match name and aliases, "hits a surface with
// property P" matches property, "hits detector D" matches kind Detector.
struct RayDatabaseObject {
    std::string name;
    ObjectKind kind = ObjectKind::Dummy;
    std::string part;
    std::string property;
    std::vector<std::string> aliases;

    bool operator==(const RayDatabaseObject&) const = default;
};
std::ostream& operator<<(std::ostream& os, const RayDatabaseObject& o);

struct RayDatabaseInfo {
    std::string sceneName;
    uint64_t sceneHash = 0;         // identifies the scene the rays were traced in (describeScene)
    uint64_t seed = 0;              // the run seed: ray i used CounterRng(seed, i)
    std::string fluxUnit = "W";     // "W" (radiometric) or "lm" (photometric)
    std::string lengthUnit = "mm";  // positions; wavelengths are always nm
    // Object ids index `objects`, medium indices `media`, an Emit event's object `sources`,
    // a scatter event's detail `scatterModels`. An empty table is not checked on reading.
    std::vector<RayDatabaseObject> objects;
    std::vector<std::string> media;
    std::vector<std::string> sources;
    std::vector<std::string> scatterModels;
    // What each event stores besides its topology and flux.
    PathEncoding encoding{.positions = true, .directions = true, .doublePrecision = false};

    bool operator==(const RayDatabaseInfo&) const = default;
};
std::ostream& operator<<(std::ostream& os, const RayDatabaseInfo& i);

// The objects and media of `scene`, and a hash of those tables (FNV-1a 64 over names, kinds,
// parts, properties, aliases and media: it tells whether names in a database still mean the
// same objects, not whether the geometry moved). Sources and scatter models are the
// caller's to fill.
RayDatabaseInfo describeScene(const Scene& scene, std::string sceneName);

// The totals in the end block.
struct RayDatabaseSummary {
    uint64_t emittedRays = 0;  // rays the run emitted (stored or not)
    uint64_t storedRays = 0;   // records
    uint64_t events = 0;       // nodes over all records
    uint64_t paths = 0;        // leaves over all records
    uint64_t chunks = 0;

    bool operator==(const RayDatabaseSummary&) const = default;
};
std::ostream& operator<<(std::ostream& os, const RayDatabaseSummary& s);

// One entry of the chunk index.
struct RayDatabaseChunk {
    uint64_t offset = 0;  // byte offset of the "VCHK" block in the file
    uint64_t firstRay = 0;
    uint32_t records = 0;

    bool operator==(const RayDatabaseChunk&) const = default;
};

// A file that cannot be written, or read as a ray database.
class RayDatabaseError : public std::runtime_error {
  public:
    RayDatabaseError(std::filesystem::path path, uint64_t offset, const std::string& message);
    const std::filesystem::path& path() const { return path_; }
    uint64_t offset() const { return offset_; }  // byte offset in the file
    const std::string& message() const { return message_; }

  private:
    std::filesystem::path path_;
    uint64_t offset_;
    std::string message_;
};

// Ray Database Writer

struct RayDatabaseOptions {
    size_t chunkBytes = size_t{1} << 20;         // a chunk closes once its payload reaches this
    size_t threadBufferBytes = size_t{1} << 18;  // a thread hands its buffer over at this size
    uint64_t firstRay = 0;                       // the lowest ray index the run will add
};

// Where a run's ray database stood at its last whole chunk: what a resumed run needs to go on
// writing the same file. Everything before `bytes` is on the system's side of the process
// (flushed after the chunk), so a killed run's `.partial` file holds it; the rays from
// `nextRay` on are written again by the resumed run.
struct RayDatabaseMark {
    uint64_t bytes = 0;    // the file's length: the header and the whole chunks
    uint64_t nextRay = 0;  // the first ray not in those chunks
    std::vector<RayDatabaseChunk> index;
    RayDatabaseSummary summary;  // stored rays, events, paths and chunks so far
    bool anyRay = false;         // whether any ray had been added or skipped, and the highest
    uint64_t highest = 0;

    bool operator==(const RayDatabaseMark&) const = default;
};

class RayDatabaseWriter {
  public:
    // Creates `<path>.partial` and writes the header. Throws RayDatabaseError if the file
    // cannot be created, std::invalid_argument for an info that cannot be stored (unknown
    // units, names longer than 2^20 bytes).
    RayDatabaseWriter(std::filesystem::path path, RayDatabaseInfo info,
                      RayDatabaseOptions options = {});
    // Goes on writing a killed run's `<path>.partial` from `mark` (a mark() of that run): the
    // file is cut back to mark.bytes, and rays below mark.nextRay are ignored when added again.
    // Rays added from there as the first run would have added them give the same file, byte
    // for byte. Throws RayDatabaseError when the partial file is missing, shorter than the
    // mark, or its header is not `info`'s.
    RayDatabaseWriter(std::filesystem::path path, RayDatabaseInfo info, RayDatabaseOptions options,
                      const RayDatabaseMark& mark);
    ~RayDatabaseWriter();  // without close(): the partial file is removed
    RayDatabaseWriter(const RayDatabaseWriter&) = delete;
    RayDatabaseWriter& operator=(const RayDatabaseWriter&) = delete;

    // Stores ray `rayIndex` with all its branches. Thread-safe; any order. Every index from
    // options.firstRay on should be added or skipped exactly once: the ordered stream writes a
    // record once all lower indices have arrived, so a missing index holds later records in
    // memory until close(). Throws std::invalid_argument for a ray added twice, an index below
    // firstRay, or ids outside the info's non-empty tables.
    void add(uint64_t rayIndex, const PathHistory& history);
    // Ray `rayIndex` was traced but is not stored (a criterion rejected it). Thread-safe.
    void skip(uint64_t rayIndex);
    // Hands every thread's buffer to the ordered stream (bounds memory between batches).
    // Not to be called concurrently with add() or skip().
    void flush();
    // The last whole chunk written (thread-safe). Before the first chunk: the header alone.
    RayDatabaseMark mark() const;
    // The emitted ray count for the end block; default: the highest index added or skipped
    // plus one.
    void setEmittedRays(uint64_t n);
    // Writes the remaining records, the index and the end block, and renames the file to
    // its final name. Not concurrently with add(). Throws RayDatabaseError on I/O failure.
    RayDatabaseSummary close();

    const std::filesystem::path& path() const;
    const RayDatabaseInfo& info() const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// Ray Database Reader

struct RayRecord {
    uint64_t rayIndex = 0;
    PathHistory history;
};

class RayDatabaseReader {
  public:
    // Reads and checks the header, the end block and the chunk index. Throws RayDatabaseError
    // for a file that is not a complete ray database (truncation names where data ends).
    explicit RayDatabaseReader(std::filesystem::path path);
    ~RayDatabaseReader();
    RayDatabaseReader(const RayDatabaseReader&) = delete;
    RayDatabaseReader& operator=(const RayDatabaseReader&) = delete;

    const std::filesystem::path& path() const { return path_; }
    const RayDatabaseInfo& info() const { return info_; }
    const RayDatabaseSummary& summary() const { return summary_; }
    const std::vector<RayDatabaseChunk>& chunks() const { return chunks_; }

    // The next stored ray in increasing ray index into `record` (its capacity is reused);
    // false after the last. Throws RayDatabaseError for a corrupt chunk. After a full pass
    // from the start the totals are checked against the end block.
    bool next(RayRecord& record);
    // Back to the first ray.
    void rewind();
    // next() continues with the first stored ray whose index is >= rayIndex.
    void seekRay(uint64_t rayIndex);

  private:
    [[noreturn]] void fail(uint64_t offset, const std::string& message) const;
    void readAt(uint64_t offset, void* data, size_t size) const;
    [[noreturn]] void diagnoseTruncation(const std::string& why) const;
    void loadChunk(size_t k);
    void checkRecord(const RayRecord& r, uint64_t recordOffset) const;

    std::filesystem::path path_;
    std::FILE* file_ = nullptr;
    uint64_t fileSize_ = 0;
    uint64_t headerSize_ = 0;
    uint64_t indexOffset_ = 0;
    RayDatabaseInfo info_;
    RayDatabaseSummary summary_;
    std::vector<RayDatabaseChunk> chunks_;

    // Iteration state.
    size_t chunk_ = 0;  // the next chunk to load
    std::vector<uint8_t> payload_;
    uint64_t payloadOffset_ = 0;  // file offset of payload_[0]
    size_t pos_ = 0;
    uint32_t recordsLeft_ = 0;
    uint64_t expectedRay_ = 0;
    bool fullPass_ = true;  // iterating from the first record: totals are checked at the end
    RayDatabaseSummary seen_;
};

// CRC-32 (IEEE 802.3, reflected, as zlib's crc32): the checksum of every block.
uint32_t crc32(const uint8_t* data, size_t size, uint32_t crc = 0);

}  // namespace veil
