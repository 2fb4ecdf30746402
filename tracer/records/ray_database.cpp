#include "tracer/records/ray_database.h"

#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <system_error>

#include "geometry/scene.h"
#include "tracer/records/path_history.h"

namespace veil {

// Ray Database Layout Constants (docs/ray-database.md)

namespace {

constexpr std::array<uint8_t, 8> kMagic = {'V', 'E', 'I', 'L', 'R', 'A', 'Y', 'S'};
constexpr uint32_t kVersion = 1;
constexpr uint32_t kFlagPositions = 1u << 0;
constexpr uint32_t kFlagDirections = 1u << 1;
constexpr uint32_t kFlagDouble = 1u << 2;
constexpr uint32_t kKnownFlags = kFlagPositions | kFlagDirections | kFlagDouble;
constexpr uint64_t kHeaderFixedBytes = 36;                           // magic .. scene hash
constexpr uint64_t kHeaderMinBytes = kHeaderFixedBytes + 3 + 4 + 4;  // 3 strings, 4 tables, CRC
constexpr uint64_t kHeaderMaxBytes = uint64_t{1} << 30;
constexpr uint64_t kChunkHeaderBytes = 24;
constexpr uint64_t kIndexEntryBytes = 20;
constexpr uint64_t kEndBytes = 56;
constexpr uint64_t kMaxStringBytes = uint64_t{1} << 20;
constexpr char kChunkMagic[4] = {'V', 'C', 'H', 'K'};
constexpr char kIndexMagic[4] = {'V', 'I', 'D', 'X'};
constexpr char kEndMagic[4] = {'V', 'E', 'N', 'D'};

constexpr std::array<ObjectKind, 9> kObjectKinds = {
    ObjectKind::LensFace,     ObjectKind::MirrorFace, ObjectKind::LensEdge,
    ObjectKind::LensFlat,     ObjectKind::Stop,       ObjectKind::Mechanics,
    ObjectKind::ImportedMesh, ObjectKind::Detector,   ObjectKind::Dummy,
};

// Little-endian writing into a byte vector.
void putU32(std::vector<uint8_t>& out, uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(uint8_t(v >> (8 * i)));
}
void putU64(std::vector<uint8_t>& out, uint64_t v) {
    for (int i = 0; i < 8; ++i) out.push_back(uint8_t(v >> (8 * i)));
}
void putBytes(std::vector<uint8_t>& out, const void* data, size_t n) {
    const auto* p = static_cast<const uint8_t*>(data);
    out.insert(out.end(), p, p + n);
}
void putString(std::vector<uint8_t>& out, const std::string& s) {
    if (s.size() > kMaxStringBytes) {
        throw std::invalid_argument(
            "ray database: a name longer than 2^20 bytes: " + s.substr(0, 40) + "...");
    }
    putVarint(out, s.size());
    putBytes(out, s.data(), s.size());
}
uint32_t getU32(const uint8_t* p) {
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= uint32_t(p[i]) << (8 * i);
    return v;
}
uint64_t getU64(const uint8_t* p) {
    uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v |= uint64_t(p[i]) << (8 * i);
    return v;
}
void patchU32(std::vector<uint8_t>& out, size_t at, uint32_t v) {
    for (int i = 0; i < 4; ++i) out[at + i] = uint8_t(v >> (8 * i));
}

uint32_t encodingFlags(const PathEncoding& e) {
    return (e.positions ? kFlagPositions : 0) | (e.directions ? kFlagDirections : 0) |
           (e.doublePrecision ? kFlagDouble : 0);
}

// The name tables, as stored in the header after the units (also hashed by describeScene).
void putTables(std::vector<uint8_t>& out, const RayDatabaseInfo& info) {
    putVarint(out, info.objects.size());
    for (const RayDatabaseObject& o : info.objects) {
        putString(out, o.name);
        putString(out, std::string(toString(o.kind)));
        putString(out, o.part);
        putString(out, o.property);
        putVarint(out, o.aliases.size());
        for (const std::string& a : o.aliases) putString(out, a);
    }
    for (const auto* names : {&info.media, &info.sources, &info.scatterModels}) {
        putVarint(out, names->size());
        for (const std::string& n : *names) putString(out, n);
    }
}

std::vector<uint8_t> encodeHeader(const RayDatabaseInfo& info) {
    if (info.fluxUnit != "W" && info.fluxUnit != "lm") {
        throw std::invalid_argument("ray database: flux unit must be W or lm, not '" +
                                    info.fluxUnit + "'");
    }
    if (info.lengthUnit != "mm") {
        throw std::invalid_argument("ray database: length unit must be mm, not '" +
                                    info.lengthUnit + "'");
    }
    std::vector<uint8_t> h;
    putBytes(h, kMagic.data(), kMagic.size());
    putU32(h, kVersion);
    putU32(h, encodingFlags(info.encoding));
    putU32(h, 0);  // header size, patched below
    putU64(h, info.seed);
    putU64(h, info.sceneHash);
    putString(h, info.sceneName);
    putString(h, info.lengthUnit);
    putString(h, info.fluxUnit);
    putTables(h, info);
    if (h.size() + 4 > kHeaderMaxBytes) {
        throw std::invalid_argument("ray database: the name tables exceed 1 GiB");
    }
    patchU32(h, 16, static_cast<uint32_t>(h.size() + 4));
    putU32(h, crc32(h.data(), h.size()));
    return h;
}

// Reads header fields at absolute offsets (the header starts at byte 0).
class HeaderCursor {
  public:
    explicit HeaderCursor(std::span<const uint8_t> b, size_t pos) : b_(b), pos_(pos) {}
    uint64_t varint() { return getVarint(b_, pos_); }
    std::string string(const char* what) {
        const size_t at = pos_;
        const uint64_t n = varint();
        if (n > kMaxStringBytes || n > b_.size() - pos_) {
            throw PathDecodeError(at, std::string("invalid length of ") + what);
        }
        std::string s(reinterpret_cast<const char*>(b_.data() + pos_), n);
        pos_ += n;
        return s;
    }
    uint64_t count(const char* what) {
        const size_t at = pos_;
        const uint64_t n = varint();
        if (n > b_.size() - pos_)
            throw PathDecodeError(at, std::string("invalid count of ") + what);
        return n;
    }
    size_t pos() const { return pos_; }

  private:
    std::span<const uint8_t> b_;
    size_t pos_;
};

ObjectKind objectKindFromString(const std::string& s, size_t at) {
    for (ObjectKind k : kObjectKinds) {
        if (toString(k) == s) return k;
    }
    throw PathDecodeError(at, "unknown object kind '" + s + "'");
}

std::string hex4(const uint8_t* p) {
    std::ostringstream os;
    os << std::hex;
    for (int i = 0; i < 4; ++i) os << (i ? " " : "") << (p[i] < 16 ? "0" : "") << int(p[i]);
    return os.str();
}

}  // namespace

// CRC-32

uint32_t crc32(const uint8_t* data, size_t size, uint32_t crc) {
    static const std::array<uint32_t, 256> table = [] {
        std::array<uint32_t, 256> t{};
        for (uint32_t i = 0; i < 256; ++i) {
            uint32_t c = i;
            for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
            t[i] = c;
        }
        return t;
    }();
    crc = ~crc;
    for (size_t i = 0; i < size; ++i) crc = table[(crc ^ data[i]) & 0xff] ^ (crc >> 8);
    return ~crc;
}

// Printing

std::ostream& operator<<(std::ostream& os, const RayDatabaseObject& o) {
    os << o.name << " (" << o.kind;
    if (!o.part.empty()) os << ", part " << o.part;
    if (!o.property.empty()) os << ", property " << o.property;
    for (const std::string& a : o.aliases) os << ", alias " << a;
    return os << ")";
}

std::ostream& operator<<(std::ostream& os, const RayDatabaseInfo& i) {
    os << "RayDatabaseInfo{scene '" << i.sceneName << "' hash " << std::hex << i.sceneHash
       << std::dec << ", seed " << i.seed << ", " << i.fluxUnit << ", " << i.lengthUnit << ", "
       << i.objects.size() << " objects, " << i.media.size() << " media, " << i.sources.size()
       << " sources, " << i.scatterModels.size() << " scatter models, " << i.encoding << "}";
    return os;
}

std::ostream& operator<<(std::ostream& os, const RayDatabaseSummary& s) {
    return os << "RayDatabaseSummary{emitted " << s.emittedRays << ", stored " << s.storedRays
              << ", events " << s.events << ", paths " << s.paths << ", chunks " << s.chunks << "}";
}

RayDatabaseError::RayDatabaseError(std::filesystem::path path, uint64_t offset,
                                   const std::string& message)
    : std::runtime_error(path.string() + ": byte " + std::to_string(offset) + ": " + message),
      path_(std::move(path)),
      offset_(offset),
      message_(message) {}

RayDatabaseInfo describeScene(const Scene& scene, std::string sceneName) {
    RayDatabaseInfo info;
    info.sceneName = std::move(sceneName);
    for (const SceneObject& o : scene.objects()) {
        info.objects.push_back({o.name, o.kind, o.part, o.property, o.aliases});
    }
    for (const Medium& m : scene.media()) info.media.push_back(m.name);
    std::vector<uint8_t> bytes;
    putTables(bytes, info);
    uint64_t h = 0xcbf29ce484222325ull;  // FNV-1a 64
    for (uint8_t b : bytes) h = (h ^ b) * 0x100000001b3ull;
    info.sceneHash = h;
    return info;
}

// Ray Database Writer Implementation

namespace {

// A ray encoded in a thread buffer, or skipped.
struct Entry {
    uint64_t ray = 0;
    size_t offset = 0, size = 0;  // bytes within the buffer
    uint64_t events = 0, paths = 0;
    bool skipped = false;
};

struct ThreadBuffer {
    std::vector<uint8_t> bytes;
    std::vector<Entry> entries;
};

struct Pending {
    std::shared_ptr<const std::vector<uint8_t>> block;
    Entry entry;
};

}  // namespace

struct RayDatabaseWriter::Impl {
    std::filesystem::path path, temp;
    RayDatabaseInfo info;
    RayDatabaseOptions options;
    std::FILE* file = nullptr;
    uint64_t offset = 0;  // bytes written so far
    bool closed = false;

    tbb::enumerable_thread_specific<ThreadBuffer> locals;

    // The ordered stream, under `mutex`.
    std::mutex mutex;
    std::map<uint64_t, Pending> pending;
    uint64_t next = 0;  // the ray index the stream waits for
    bool anyRay = false;
    uint64_t highest = 0;
    std::optional<uint64_t> emitted;
    std::vector<uint8_t> chunk;
    uint64_t chunkFirst = 0, prevRay = 0;
    uint32_t chunkRecords = 0;
    std::vector<RayDatabaseChunk> index;
    RayDatabaseSummary summary;
    // After the last whole chunk (mark()): all but the index, of which the first
    // lastMarkChunks entries (the index only grows; copied when a mark is asked for).
    RayDatabaseMark lastMark;
    size_t lastMarkChunks = 0;
    uint64_t resumeBelow = 0;  // a resumed writer ignores the rays below this

    // The file, its partial name, what it describes and the options (chunk size clamped).
    void name(std::filesystem::path p, RayDatabaseInfo i, const RayDatabaseOptions& o) {
        path = std::move(p);
        temp = path;
        temp += ".partial";
        info = std::move(i);
        options = o;
        options.chunkBytes = std::clamp<size_t>(o.chunkBytes, 1, size_t{1} << 31);
    }

    void write(const uint8_t* data, size_t n) {
        if (n != 0 && std::fwrite(data, 1, n, file) != n) {
            throw RayDatabaseError(temp, offset,
                                   std::string("write failed: ") + std::strerror(errno));
        }
        offset += n;
    }

    void checkIds(uint64_t ray, const PathHistory& h) const {
        auto bad = [&](size_t i, const std::string& what) {
            throw std::invalid_argument("ray database: ray " + std::to_string(ray) + " event " +
                                        std::to_string(i) + ": " + what);
        };
        const std::span<const PathNode> nodes = h.nodes();
        for (size_t i = 0; i < nodes.size(); ++i) {
            const PathNode& n = nodes[i];
            if (i == 0 && !info.sources.empty() &&
                static_cast<size_t>(n.object) >= info.sources.size()) {
                bad(i, "source " + std::to_string(n.object) + " outside the source table");
            }
            if (i > 0 && !info.objects.empty() && n.object >= 0 &&
                static_cast<size_t>(n.object) >= info.objects.size()) {
                bad(i, "object " + std::to_string(n.object) + " outside the object table");
            }
            if (!info.media.empty() && static_cast<size_t>(n.medium) >= info.media.size()) {
                bad(i, "medium " + std::to_string(n.medium) + " outside the media table");
            }
            if ((n.type == EventType::ScatterReflect || n.type == EventType::ScatterTransmit) &&
                !info.scatterModels.empty() && n.detail >= info.scatterModels.size()) {
                bad(i, "scatter model " + std::to_string(n.detail) + " outside the table");
            }
        }
    }

    void handOff(ThreadBuffer& tb) {
        if (tb.entries.empty()) return;
        auto block = std::make_shared<const std::vector<uint8_t>>(std::move(tb.bytes));
        std::vector<Entry> entries = std::move(tb.entries);
        tb.bytes = {};
        tb.entries = {};
        std::lock_guard<std::mutex> lock(mutex);
        for (const Entry& e : entries) {
            if (e.ray < next || pending.count(e.ray)) {
                throw std::invalid_argument("ray database: ray " + std::to_string(e.ray) +
                                            (e.ray < options.firstRay ? " is below the first ray"
                                                                      : " added or skipped twice"));
            }
            pending.emplace(e.ray, Pending{block, e});
            if (!anyRay || e.ray > highest) highest = e.ray;
            anyRay = true;
        }
        drain(false);
    }

    // Writes pending records in ray order: those that follow without a gap, or all.
    void drain(bool all) {
        while (!pending.empty() && (all || pending.begin()->first == next)) {
            const auto it = pending.begin();
            const Entry& e = it->second.entry;
            if (!e.skipped) {
                appendRecord(e, it->second.block->data() + e.offset);
            }
            next = e.ray + 1;
            pending.erase(it);
        }
    }

    void appendRecord(const Entry& e, const uint8_t* bytes) {
        if (chunkRecords == 0) {
            chunkFirst = e.ray;
            putVarint(chunk, 0);
        } else {
            putVarint(chunk, e.ray - (prevRay + 1));
        }
        chunk.insert(chunk.end(), bytes, bytes + e.size);
        prevRay = e.ray;
        ++chunkRecords;
        ++summary.storedRays;
        summary.events += e.events;
        summary.paths += e.paths;
        if (chunk.size() >= options.chunkBytes) writeChunk();
    }

    void writeChunk() {
        if (chunkRecords == 0) return;
        if (chunk.size() > 0xffffffffu) {
            throw RayDatabaseError(temp, offset, "a chunk payload over 4 GiB");
        }
        index.push_back({offset, chunkFirst, chunkRecords});
        std::vector<uint8_t> h;
        putBytes(h, kChunkMagic, 4);
        putU32(h, static_cast<uint32_t>(chunk.size()));
        putU64(h, chunkFirst);
        putU32(h, chunkRecords);
        putU32(h, crc32(chunk.data(), chunk.size()));
        write(h.data(), h.size());
        write(chunk.data(), chunk.size());
        chunk.clear();
        chunkRecords = 0;
        ++summary.chunks;
        // The chunk on the system's side, so a killed process leaves it in the file.
        if (std::fflush(file) != 0)
            throw RayDatabaseError(temp, offset,
                                   std::string("write failed: ") + std::strerror(errno));
        setMark(prevRay + 1);
    }

    // The mark after the file's last whole chunk (or its header): the rays below nextRay are
    // in it.
    void setMark(uint64_t nextRay) {
        lastMark.bytes = offset;
        lastMark.nextRay = nextRay;
        lastMarkChunks = index.size();
        lastMark.summary = summary;
        lastMark.anyRay = nextRay > options.firstRay;
        lastMark.highest = lastMark.anyRay ? nextRay - 1 : 0;
    }

    void abandon() noexcept {
        if (file) std::fclose(file);
        file = nullptr;
        std::error_code ec;
        std::filesystem::remove(temp, ec);
    }
};

RayDatabaseWriter::RayDatabaseWriter(std::filesystem::path path, RayDatabaseInfo info,
                                     RayDatabaseOptions options)
    : impl_(std::make_unique<Impl>()) {
    Impl& w = *impl_;
    w.name(std::move(path), std::move(info), options);
    w.next = options.firstRay;
    const std::vector<uint8_t> header = encodeHeader(w.info);
    w.file = std::fopen(w.temp.c_str(), "wb");
    if (!w.file) {
        throw RayDatabaseError(w.temp, 0, std::string("cannot create: ") + std::strerror(errno));
    }
    try {
        w.write(header.data(), header.size());
        if (std::fflush(w.file) != 0)
            throw RayDatabaseError(w.temp, 0, std::string("write failed: ") + std::strerror(errno));
    } catch (...) {
        w.abandon();
        throw;
    }
    w.resumeBelow = w.next;
    w.setMark(w.next);
}

RayDatabaseMark RayDatabaseWriter::mark() const {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    RayDatabaseMark m = impl_->lastMark;
    m.index.assign(impl_->index.begin(),
                   impl_->index.begin() + static_cast<std::ptrdiff_t>(impl_->lastMarkChunks));
    return m;
}

RayDatabaseWriter::RayDatabaseWriter(std::filesystem::path path, RayDatabaseInfo info,
                                     RayDatabaseOptions options, const RayDatabaseMark& mark)
    : impl_(std::make_unique<Impl>()) {
    Impl& w = *impl_;
    w.name(std::move(path), std::move(info), options);
    const std::vector<uint8_t> header = encodeHeader(w.info);
    std::error_code ec;
    const uint64_t size = std::filesystem::file_size(w.temp, ec);
    if (ec)
        throw RayDatabaseError(w.temp, 0,
                               "cannot continue the run's ray database: " + ec.message());
    if (size < mark.bytes || mark.bytes < header.size())
        throw RayDatabaseError(w.temp, size,
                               "holds " + std::to_string(size) + " bytes, not the " +
                                   std::to_string(mark.bytes) + " the run had written");
    w.file = std::fopen(w.temp.c_str(), "r+b");
    if (!w.file)
        throw RayDatabaseError(w.temp, 0, std::string("cannot open: ") + std::strerror(errno));
    std::vector<uint8_t> head(header.size());
    if (std::fread(head.data(), 1, head.size(), w.file) != head.size() || head != header) {
        std::fclose(w.file);
        w.file = nullptr;
        throw RayDatabaseError(w.temp, 0,
                               "its header is not this run's (another scene or options)");
    }
    std::filesystem::resize_file(w.temp, mark.bytes, ec);
    if (ec || std::fseek(w.file, static_cast<long>(mark.bytes), SEEK_SET) != 0) {
        std::fclose(w.file);
        w.file = nullptr;
        throw RayDatabaseError(w.temp, mark.bytes,
                               "cannot cut back: " + (ec ? ec.message() : std::strerror(errno)));
    }
    w.offset = mark.bytes;
    w.next = std::max(mark.nextRay, options.firstRay);
    w.resumeBelow = w.next;
    w.index = mark.index;
    w.summary = mark.summary;
    w.anyRay = mark.anyRay;
    w.highest = mark.highest;
    w.lastMark = mark;
    w.lastMark.index.clear();
    w.lastMarkChunks = mark.index.size();
}

RayDatabaseWriter::~RayDatabaseWriter() {
    if (impl_ && !impl_->closed) impl_->abandon();
}

void RayDatabaseWriter::add(uint64_t rayIndex, const PathHistory& history) {
    Impl& w = *impl_;
    if (rayIndex < w.resumeBelow && rayIndex >= w.options.firstRay) return;  // written before
    if (rayIndex < w.options.firstRay) {
        throw std::invalid_argument("ray database: ray " + std::to_string(rayIndex) +
                                    " is below the first ray " +
                                    std::to_string(w.options.firstRay));
    }
    w.checkIds(rayIndex, history);
    ThreadBuffer& tb = w.locals.local();
    Entry e;
    e.ray = rayIndex;
    e.offset = tb.bytes.size();
    encodeHistory(history, w.info.encoding, tb.bytes);
    e.size = tb.bytes.size() - e.offset;
    e.events = history.size();
    e.paths = history.pathCount();
    tb.entries.push_back(e);
    if (tb.bytes.size() >= w.options.threadBufferBytes) w.handOff(tb);
}

void RayDatabaseWriter::skip(uint64_t rayIndex) {
    Impl& w = *impl_;
    if (rayIndex < w.resumeBelow && rayIndex >= w.options.firstRay) return;  // written before
    if (rayIndex < w.options.firstRay) {
        throw std::invalid_argument("ray database: ray " + std::to_string(rayIndex) +
                                    " is below the first ray");
    }
    ThreadBuffer& tb = w.locals.local();
    Entry e;
    e.ray = rayIndex;
    e.offset = tb.bytes.size();
    e.skipped = true;
    tb.entries.push_back(e);
    // Skips carry no bytes: hand over by count too, so a thread that only skips is not
    // holding the stream back until close().
    if (tb.entries.size() >= 4096) w.handOff(tb);
}

void RayDatabaseWriter::flush() {
    for (ThreadBuffer& tb : impl_->locals) impl_->handOff(tb);
}

void RayDatabaseWriter::setEmittedRays(uint64_t n) { impl_->emitted = n; }

RayDatabaseSummary RayDatabaseWriter::close() {
    Impl& w = *impl_;
    if (w.closed) return w.summary;
    try {
        flush();
        {
            std::lock_guard<std::mutex> lock(w.mutex);
            w.drain(true);
        }
        w.writeChunk();
        const uint64_t highestPlusOne = w.anyRay ? w.highest + 1 : 0;
        w.summary.emittedRays = std::max(w.emitted.value_or(0), highestPlusOne);

        // Chunk index.
        const uint64_t indexOffset = w.offset;
        std::vector<uint8_t> b;
        putBytes(b, kIndexMagic, 4);
        putU32(b, static_cast<uint32_t>(w.index.size()));
        for (const RayDatabaseChunk& c : w.index) {
            putU64(b, c.offset);
            putU64(b, c.firstRay);
            putU32(b, c.records);
        }
        putU32(b, crc32(b.data(), b.size()));
        w.write(b.data(), b.size());

        // End block.
        b.clear();
        putBytes(b, kEndMagic, 4);
        putU32(b, 0);  // CRC, patched below
        putU64(b, indexOffset);
        putU64(b, w.summary.emittedRays);
        putU64(b, w.summary.storedRays);
        putU64(b, w.summary.events);
        putU64(b, w.summary.paths);
        putU64(b, w.summary.chunks);
        patchU32(b, 4, crc32(b.data() + 8, b.size() - 8));
        w.write(b.data(), b.size());

        if (std::fflush(w.file) != 0 || std::fclose(w.file) != 0) {
            w.file = nullptr;
            throw RayDatabaseError(w.temp, w.offset,
                                   std::string("write failed: ") + std::strerror(errno));
        }
        w.file = nullptr;
        std::error_code ec;
        std::filesystem::rename(w.temp, w.path, ec);
        if (ec) {
            throw RayDatabaseError(w.path, 0,
                                   "cannot rename " + w.temp.string() + ": " + ec.message());
        }
    } catch (...) {
        w.abandon();
        w.closed = true;
        throw;
    }
    w.closed = true;
    return w.summary;
}

const std::filesystem::path& RayDatabaseWriter::path() const { return impl_->path; }
const RayDatabaseInfo& RayDatabaseWriter::info() const { return impl_->info; }

// Ray Database Reader Implementation

RayDatabaseReader::RayDatabaseReader(std::filesystem::path path) : path_(std::move(path)) {
    file_ = std::fopen(path_.c_str(), "rb");
    if (!file_) fail(0, std::string("cannot open: ") + std::strerror(errno));
    try {
        std::error_code ec;
        fileSize_ = std::filesystem::file_size(path_, ec);
        if (ec) fail(0, "cannot read the size: " + ec.message());

        // Fixed part of the header.
        uint8_t fixed[kHeaderFixedBytes] = {};
        const uint64_t have = std::min<uint64_t>(fileSize_, kHeaderFixedBytes);
        readAt(0, fixed, have);
        if (std::memcmp(fixed, kMagic.data(), std::min<uint64_t>(have, kMagic.size())) != 0) {
            fail(0, "not a veil ray database (the file does not start with VEILRAYS)");
        }
        if (fileSize_ < kHeaderFixedBytes) {
            fail(fileSize_,
                 "truncated in the header: the file ends at byte " + std::to_string(fileSize_));
        }
        const uint32_t version = getU32(fixed + 8);
        if (version != kVersion) {
            fail(8, "unsupported format version " + std::to_string(version) +
                        " (this reader: " + std::to_string(kVersion) + ")");
        }
        const uint32_t flags = getU32(fixed + 12);
        if (flags & ~kKnownFlags) fail(12, "unknown flags " + std::to_string(flags));
        headerSize_ = getU32(fixed + 16);
        if (headerSize_ < kHeaderMinBytes || headerSize_ > kHeaderMaxBytes) {
            fail(16, "invalid header size " + std::to_string(headerSize_));
        }
        if (fileSize_ < headerSize_) {
            fail(fileSize_, "truncated in the header: the file ends at byte " +
                                std::to_string(fileSize_) + ", the header needs " +
                                std::to_string(headerSize_) + " bytes");
        }

        // The whole header, checked, then parsed.
        std::vector<uint8_t> h(headerSize_);
        readAt(0, h.data(), h.size());
        const uint32_t stored = getU32(h.data() + h.size() - 4);
        const uint32_t computed = crc32(h.data(), h.size() - 4);
        if (stored != computed) {
            fail(0, "header checksum mismatch over bytes 0 to " + std::to_string(headerSize_) +
                        " (the header is corrupt)");
        }
        info_.encoding.positions = flags & kFlagPositions;
        info_.encoding.directions = flags & kFlagDirections;
        info_.encoding.doublePrecision = flags & kFlagDouble;
        info_.seed = getU64(h.data() + 20);
        info_.sceneHash = getU64(h.data() + 28);
        const std::span<const uint8_t> body(h.data(), h.size() - 4);
        try {
            HeaderCursor c(body, kHeaderFixedBytes);
            info_.sceneName = c.string("the scene name");
            info_.lengthUnit = c.string("the length unit");
            info_.fluxUnit = c.string("the flux unit");
            const uint64_t objects = c.count("objects");
            info_.objects.resize(objects);
            for (RayDatabaseObject& o : info_.objects) {
                o.name = c.string("an object name");
                const size_t kindAt = c.pos();
                o.kind = objectKindFromString(c.string("an object kind"), kindAt);
                o.part = c.string("an object part");
                o.property = c.string("an object property");
                o.aliases.resize(c.count("aliases"));
                for (std::string& a : o.aliases) a = c.string("an alias");
            }
            for (auto* names : {&info_.media, &info_.sources, &info_.scatterModels}) {
                names->resize(c.count("names"));
                for (std::string& n : *names) n = c.string("a name");
            }
            if (c.pos() != body.size()) {
                throw PathDecodeError(c.pos(), "unexpected bytes after the name tables");
            }
        } catch (const PathDecodeError& e) {
            fail(e.offset(), "header: " + e.message());
        }

        // End block.
        if (fileSize_ < headerSize_ + kEndBytes) diagnoseTruncation("no end block");
        const uint64_t endAt = fileSize_ - kEndBytes;
        uint8_t end[kEndBytes];
        readAt(endAt, end, kEndBytes);
        if (std::memcmp(end, kEndMagic, 4) != 0) diagnoseTruncation("no end block");
        if (getU32(end + 4) != crc32(end + 8, kEndBytes - 8)) {
            diagnoseTruncation("end block checksum mismatch (the end block is corrupt)");
        }
        indexOffset_ = getU64(end + 8);
        summary_.emittedRays = getU64(end + 16);
        summary_.storedRays = getU64(end + 24);
        summary_.events = getU64(end + 32);
        summary_.paths = getU64(end + 40);
        summary_.chunks = getU64(end + 48);
        if (summary_.chunks > (endAt - headerSize_) / kIndexEntryBytes ||
            indexOffset_ < headerSize_ ||
            indexOffset_ + 8 + kIndexEntryBytes * summary_.chunks + 4 != endAt) {
            fail(endAt, "end block: index offset " + std::to_string(indexOffset_) + " and " +
                            std::to_string(summary_.chunks) +
                            " chunks do not fit the file (the end block is corrupt)");
        }

        // Chunk index.
        std::vector<uint8_t> idx(endAt - indexOffset_);
        readAt(indexOffset_, idx.data(), idx.size());
        if (std::memcmp(idx.data(), kIndexMagic, 4) != 0 ||
            getU32(idx.data() + 4) != summary_.chunks) {
            fail(indexOffset_,
                 "expected the chunk index of " + std::to_string(summary_.chunks) + " chunks");
        }
        if (getU32(idx.data() + idx.size() - 4) != crc32(idx.data(), idx.size() - 4)) {
            fail(indexOffset_, "chunk index checksum mismatch (the index is corrupt)");
        }
        uint64_t records = 0;
        for (uint64_t k = 0; k < summary_.chunks; ++k) {
            const uint8_t* p = idx.data() + 8 + kIndexEntryBytes * k;
            RayDatabaseChunk c{getU64(p), getU64(p + 8), getU32(p + 16)};
            const bool ordered =
                k == 0 ? c.offset == headerSize_
                       : c.offset > chunks_.back().offset && c.firstRay > chunks_.back().firstRay;
            if (!ordered || c.offset + kChunkHeaderBytes > indexOffset_ || c.records == 0) {
                fail(indexOffset_ + 8 + kIndexEntryBytes * k,
                     "chunk index entry " + std::to_string(k) + " is inconsistent");
            }
            records += c.records;
            chunks_.push_back(c);
        }
        if (records != summary_.storedRays ||
            (summary_.chunks == 0 && indexOffset_ != headerSize_)) {
            fail(endAt, "end block: " + std::to_string(summary_.storedRays) +
                            " stored rays, the index lists " + std::to_string(records));
        }
    } catch (...) {
        std::fclose(file_);
        file_ = nullptr;
        throw;
    }
}

RayDatabaseReader::~RayDatabaseReader() {
    if (file_) std::fclose(file_);
}

void RayDatabaseReader::fail(uint64_t offset, const std::string& message) const {
    throw RayDatabaseError(path_, offset, message);
}

void RayDatabaseReader::readAt(uint64_t offset, void* data, size_t size) const {
    if (size == 0) return;
    if (fseeko(file_, static_cast<off_t>(offset), SEEK_SET) != 0 ||
        std::fread(data, 1, size, file_) != size) {
        fail(offset,
             "cannot read " + std::to_string(size) + " bytes (the file changed or is unreadable)");
    }
}

// Explains a missing or damaged end block: walks the blocks from the header on and names the
// first one the file does not hold completely.
void RayDatabaseReader::diagnoseTruncation(const std::string& why) const {
    const std::string ends = ", the file ends at byte " + std::to_string(fileSize_);
    uint64_t off = headerSize_;
    for (uint64_t k = 0;; ++k) {
        if (off == fileSize_) {
            fail(off, "truncated: the file ends after " + std::to_string(k) +
                          " complete chunks, without the chunk index and end block (was the "
                          "writer closed?)");
        }
        uint8_t b[kChunkHeaderBytes] = {};
        const uint64_t have = std::min<uint64_t>(fileSize_ - off, kChunkHeaderBytes);
        readAt(off, b, have);
        if (have < 4) fail(off, "truncated: a partial block header" + ends);
        if (std::memcmp(b, kChunkMagic, 4) == 0) {
            if (have < kChunkHeaderBytes) {
                fail(off, "truncated: the header of chunk " + std::to_string(k) + " is cut" + ends);
            }
            const uint64_t size = kChunkHeaderBytes + getU32(b + 4);
            if (fileSize_ - off < size) {
                fail(off, "truncated: chunk " + std::to_string(k) + " needs " +
                              std::to_string(size) + " bytes" + ends);
            }
            off += size;
            continue;
        }
        if (std::memcmp(b, kIndexMagic, 4) == 0) {
            if (have < 8) fail(off, "truncated: the chunk index header is cut" + ends);
            const uint64_t size = 8 + kIndexEntryBytes * getU32(b + 4) + 4;
            if (fileSize_ - off < size) {
                fail(off,
                     "truncated: the chunk index needs " + std::to_string(size) + " bytes" + ends);
            }
            off += size;
            if (off == fileSize_) fail(off, "truncated: the end block is missing" + ends);
            if (fileSize_ - off < kEndBytes) fail(off, "truncated: the end block is cut" + ends);
            fail(off, why);
        }
        if (std::memcmp(b, kEndMagic, 4) == 0) {
            if (fileSize_ - off < kEndBytes) fail(off, "truncated: the end block is cut" + ends);
            fail(off, why);
        }
        fail(off,
             "corrupt: expected a chunk, the chunk index or the end block, found bytes " + hex4(b));
    }
}

void RayDatabaseReader::loadChunk(size_t k) {
    const RayDatabaseChunk& c = chunks_[k];
    const uint64_t blockEnd = k + 1 < chunks_.size() ? chunks_[k + 1].offset : indexOffset_;
    uint8_t h[kChunkHeaderBytes];
    readAt(c.offset, h, kChunkHeaderBytes);
    const std::string name = "chunk " + std::to_string(k);
    if (std::memcmp(h, kChunkMagic, 4) != 0) {
        fail(c.offset, name + ": expected VCHK, found bytes " + hex4(h));
    }
    const uint64_t size = getU32(h + 4);
    if (c.offset + kChunkHeaderBytes + size != blockEnd || getU64(h + 8) != c.firstRay ||
        getU32(h + 16) != c.records) {
        fail(c.offset, name + ": header disagrees with the chunk index");
    }
    payload_.resize(size);
    readAt(c.offset + kChunkHeaderBytes, payload_.data(), size);
    if (getU32(h + 20) != crc32(payload_.data(), payload_.size())) {
        fail(c.offset, name + ": checksum mismatch over bytes " +
                           std::to_string(c.offset + kChunkHeaderBytes) + " to " +
                           std::to_string(blockEnd) + " (the chunk is corrupt)");
    }
    payloadOffset_ = c.offset + kChunkHeaderBytes;
    pos_ = 0;
    recordsLeft_ = c.records;
    expectedRay_ = c.firstRay;
    chunk_ = k + 1;
}

void RayDatabaseReader::checkRecord(const RayRecord& r, uint64_t recordOffset) const {
    const std::span<const PathNode> nodes = r.history.nodes();
    auto bad = [&](size_t i, const std::string& what) {
        fail(recordOffset,
             "ray " + std::to_string(r.rayIndex) + " event " + std::to_string(i) + ": " + what);
    };
    for (size_t i = 0; i < nodes.size(); ++i) {
        const PathNode& n = nodes[i];
        if (i == 0 && !info_.sources.empty() &&
            static_cast<size_t>(n.object) >= info_.sources.size()) {
            bad(i, "source " + std::to_string(n.object) + " outside the source table");
        }
        if (i > 0 && !info_.objects.empty() && n.object >= 0 &&
            static_cast<size_t>(n.object) >= info_.objects.size()) {
            bad(i, "object " + std::to_string(n.object) + " outside the object table");
        }
        if (!info_.media.empty() && static_cast<size_t>(n.medium) >= info_.media.size()) {
            bad(i, "medium " + std::to_string(n.medium) + " outside the media table");
        }
    }
}

bool RayDatabaseReader::next(RayRecord& record) {
    while (recordsLeft_ == 0) {
        if (chunk_ >= chunks_.size()) {
            if (fullPass_) {
                fullPass_ = false;  // checked once
                if (seen_.storedRays != summary_.storedRays || seen_.events != summary_.events ||
                    seen_.paths != summary_.paths) {
                    fail(fileSize_ - kEndBytes,
                         "end block totals (" + std::to_string(summary_.storedRays) + " rays, " +
                             std::to_string(summary_.events) + " events) differ from the chunks (" +
                             std::to_string(seen_.storedRays) + " rays, " +
                             std::to_string(seen_.events) + " events)");
                }
            }
            return false;
        }
        // Chunks in order: the index has increasing first rays, and the last ray of the
        // previous chunk must also come before this one.
        if (chunk_ > 0 && chunks_[chunk_].firstRay < expectedRay_) {
            fail(chunks_[chunk_].offset, "chunk " + std::to_string(chunk_) +
                                             ": starts at a ray before the previous chunk's last");
        }
        loadChunk(chunk_);
    }
    const uint64_t recordOffset = payloadOffset_ + pos_;
    auto where = [&] { return "chunk " + std::to_string(chunk_ - 1) + ": "; };
    try {
        const size_t deltaAt = pos_;
        const uint64_t delta = getVarint(payload_, pos_);
        const bool first = recordsLeft_ == chunks_[chunk_ - 1].records;
        if ((first && delta != 0) || delta > ~uint64_t{0} - expectedRay_) {
            throw PathDecodeError(deltaAt, "invalid ray index delta " + std::to_string(delta));
        }
        record.rayIndex = expectedRay_ + delta;
        decodeHistory(payload_, pos_, info_.encoding, record.history);
    } catch (const PathDecodeError& e) {
        fail(payloadOffset_ + e.offset(), where() + e.message());
    }
    --recordsLeft_;
    if (recordsLeft_ == 0 && pos_ != payload_.size()) {
        fail(payloadOffset_ + pos_, where() + "bytes after the last record");
    }
    if (recordsLeft_ > 0 && pos_ == payload_.size()) {
        fail(payloadOffset_ + pos_, where() + "fewer records than its header says");
    }
    checkRecord(record, recordOffset);
    expectedRay_ = record.rayIndex + 1;
    ++seen_.storedRays;
    seen_.events += record.history.size();
    seen_.paths += record.history.pathCount();
    return true;
}

void RayDatabaseReader::rewind() {
    chunk_ = 0;
    payload_.clear();
    pos_ = 0;
    recordsLeft_ = 0;
    expectedRay_ = 0;
    fullPass_ = true;
    seen_ = {};
}

void RayDatabaseReader::seekRay(uint64_t rayIndex) {
    rewind();
    fullPass_ = false;
    // The last chunk starting at or before rayIndex; the rays before it are skipped by decoding.
    const auto it =
        std::upper_bound(chunks_.begin(), chunks_.end(), rayIndex,
                         [](uint64_t r, const RayDatabaseChunk& c) { return r < c.firstRay; });
    if (it == chunks_.begin()) return;
    const size_t k = static_cast<size_t>(it - chunks_.begin()) - 1;
    loadChunk(k);
    RayRecord scratch;
    while (recordsLeft_ > 0) {
        const size_t pos = pos_;
        const uint32_t left = recordsLeft_;
        const uint64_t expected = expectedRay_;
        next(scratch);
        if (scratch.rayIndex >= rayIndex) {
            pos_ = pos;
            recordsLeft_ = left;
            expectedRay_ = expected;
            return;
        }
    }
}

}  // namespace veil
