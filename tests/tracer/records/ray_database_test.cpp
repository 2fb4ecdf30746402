// The ray database file: write/read round trips of random split histories, bytes that do not
// depend on the order (or threads) rays are added in, and truncated or corrupted files that
// fail with the file name and the byte offset of the damage.

#include "tracer/records/ray_database.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <numeric>
#include <random>
#include <thread>

#include "geometry/scene.h"
#include "tracer/records/path_history.h"
#include "tracer/runtime/rng.h"

namespace veil {

// From path_history_test.cpp.
PathHistory randomHistory(uint64_t seed, uint64_t ray, int maxEvents);
void expectStored(const PathHistory& original, const PathHistory& decoded, const PathEncoding& enc);

namespace {

std::filesystem::path tempFile(const std::string& name) {
    return std::filesystem::path(::testing::TempDir()) /
           ("veil_raydb_" + std::to_string(::getpid()) + "_" + name + ".vrdb");
}

std::vector<uint8_t> readBytes(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void writeBytes(const std::filesystem::path& p, const std::vector<uint8_t>& b) {
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

// Scene-like tables matching randomHistory's ids: 41 objects, 7 media, 3 sources, 3 models.
RayDatabaseInfo testInfo() {
    RayDatabaseInfo info;
    info.sceneName = "Double Gauss 50 mm f/2 (test tables)";
    info.sceneHash = 0x0123456789abcdefull;
    info.seed = 42;
    info.fluxUnit = "lm";
    for (int i = 0; i < 24; ++i) {
        RayDatabaseObject o;
        // (Appending instead of "L" + to_string(): GCC 12 warns falsely on that, bug 105329.)
        o.part = "L";
        o.part += std::to_string(i / 2 + 1);
        o.name = o.part;
        o.name += i % 2 ? ".back" : ".front";
        o.kind = ObjectKind::LensFace;
        o.property = i % 3 ? "ideal_ar" : "uncoated";
        if (i % 2 == 1) o.aliases.push_back("S" + std::to_string(i + 1));
        info.objects.push_back(o);
    }
    for (int i = 0; i < 16; ++i) {
        info.objects.push_back({"spacer" + std::to_string(i),
                                ObjectKind::Mechanics,
                                "spacer" + std::to_string(i),
                                "black_anodized",
                                {}});
    }
    info.objects.push_back({"sensor", ObjectKind::Detector, "sensor", "", {}});
    info.media = {"air", "N-SK2", "N-SF5", "N-BK7", "F2", "N-LAK9", "SF57"};
    info.sources = {"sun", "lamp", "window"};
    info.scatterModels = {"lambertian", "gaussian", "abg"};
    return info;
}

// Writes rays [0, n) in the given order from one thread; every 7th ray is skipped.
RayDatabaseSummary writeRays(const std::filesystem::path& p, const std::vector<uint64_t>& order,
                             const RayDatabaseOptions& options, const RayDatabaseInfo& info) {
    RayDatabaseWriter w(p, info, options);
    for (uint64_t ray : order) {
        if (ray % 7 == 3) {
            w.skip(ray);
        } else {
            w.add(ray, randomHistory(2024, ray, 150));
        }
    }
    return w.close();
}

std::vector<uint64_t> iota(uint64_t n) {
    std::vector<uint64_t> v(n);
    std::iota(v.begin(), v.end(), uint64_t{0});
    return v;
}

RayDatabaseOptions smallChunks() {
    RayDatabaseOptions o;
    o.chunkBytes = 8192;  // many chunks from a small run
    o.threadBufferBytes = 3000;
    return o;
}

TEST(Crc32, MatchesTheStandardCheckValue) {
    const std::string s = "123456789";
    EXPECT_EQ(crc32(reinterpret_cast<const uint8_t*>(s.data()), s.size()), 0xCBF43926u);
    // Chained in two parts as one.
    const uint32_t a = crc32(reinterpret_cast<const uint8_t*>(s.data()), 4);
    EXPECT_EQ(crc32(reinterpret_cast<const uint8_t*>(s.data()) + 4, 5, a), 0xCBF43926u);
}

TEST(RayDatabase, WriteReadRoundTripIsIdentical) {
    const auto p = tempFile("roundtrip");
    const RayDatabaseInfo info = testInfo();
    const uint64_t n = 1500;
    const RayDatabaseSummary written = writeRays(p, iota(n), smallChunks(), info);
    EXPECT_FALSE(std::filesystem::exists(p.string() + ".partial"));

    RayDatabaseReader r(p);
    EXPECT_EQ(r.info(), info);  // names, kinds, aliases, units, hash, seed, encoding
    EXPECT_EQ(r.summary(), written);
    EXPECT_EQ(r.summary().emittedRays, n);
    EXPECT_GT(r.summary().chunks, 10u);
    EXPECT_EQ(r.chunks().size(), r.summary().chunks);

    RayRecord rec;
    uint64_t expectedRay = 0, events = 0, paths = 0, stored = 0;
    while (r.next(rec)) {
        while (expectedRay % 7 == 3) ++expectedRay;  // skipped rays are not stored
        ASSERT_EQ(rec.rayIndex, expectedRay);
        const PathHistory h = randomHistory(2024, expectedRay, 150);
        expectStored(h, rec.history, info.encoding);
        ASSERT_FALSE(::testing::Test::HasFatalFailure()) << "ray " << expectedRay;
        events += h.size();
        paths += h.pathCount();
        ++stored;
        ++expectedRay;
    }
    EXPECT_EQ(stored, written.storedRays);
    EXPECT_EQ(events, written.events);
    EXPECT_EQ(paths, written.paths);

    // A second pass after rewind gives the same records.
    r.rewind();
    ASSERT_TRUE(r.next(rec));
    EXPECT_EQ(rec.rayIndex, 0u);
    std::filesystem::remove(p);
}

TEST(RayDatabase, DoublePrecisionWithoutGeometryRoundTrips) {
    for (const PathEncoding enc : {PathEncoding{false, false, true}, PathEncoding{}}) {
        const auto p = tempFile("encoding");
        RayDatabaseInfo info = testInfo();
        info.encoding = enc;
        writeRays(p, iota(300), {}, info);
        RayDatabaseReader r(p);
        EXPECT_EQ(r.info().encoding, enc);
        RayRecord rec;
        size_t count = 0;
        while (r.next(rec)) {
            expectStored(randomHistory(2024, rec.rayIndex, 150), rec.history, enc);
            ASSERT_FALSE(::testing::Test::HasFatalFailure()) << enc << " ray " << rec.rayIndex;
            ++count;
        }
        EXPECT_EQ(count, r.summary().storedRays);
        EXPECT_EQ(r.summary().chunks, 1u);  // 300 rays fit the default 1 MiB chunk
        std::filesystem::remove(p);
    }
}

TEST(RayDatabase, FileBytesDoNotDependOnAddOrderOrThreads) {
    const RayDatabaseInfo info = testInfo();
    const uint64_t n = 2000;
    const auto inOrder = tempFile("ordered");
    writeRays(inOrder, iota(n), smallChunks(), info);
    const std::vector<uint8_t> reference = readBytes(inOrder);
    ASSERT_GT(reference.size(), 50000u);

    // Shuffled adds from one thread.
    std::vector<uint64_t> order = iota(n);
    std::mt19937_64 shuffle(7);
    std::shuffle(order.begin(), order.end(), shuffle);
    const auto shuffled = tempFile("shuffled");
    writeRays(shuffled, order, smallChunks(), info);
    EXPECT_TRUE(readBytes(shuffled) == reference) << "shuffled adds changed the file";

    // Four threads, each adding an interleaved share in its own shuffled order, with a flush
    // in the middle as a tracer does between batches.
    for (int threads : {2, 4}) {
        const auto parallel = tempFile("threads" + std::to_string(threads));
        RayDatabaseWriter w(parallel, info, smallChunks());
        auto work = [&](int t, uint64_t begin, uint64_t end) {
            std::vector<uint64_t> mine;
            for (uint64_t ray = begin; ray < end; ++ray) {
                if (static_cast<int>(ray % threads) == t) mine.push_back(ray);
            }
            std::mt19937_64 rng(100 + t);
            std::shuffle(mine.begin(), mine.end(), rng);
            for (uint64_t ray : mine) {
                if (ray % 7 == 3) {
                    w.skip(ray);
                } else {
                    w.add(ray, randomHistory(2024, ray, 150));
                }
            }
        };
        for (auto [begin, end] : {std::pair<uint64_t, uint64_t>{0, n / 2}, {n / 2, n}}) {
            std::vector<std::thread> pool;
            for (int t = 0; t < threads; ++t) pool.emplace_back(work, t, begin, end);
            for (std::thread& th : pool) th.join();
            w.flush();
        }
        w.close();
        EXPECT_TRUE(readBytes(parallel) == reference) << threads << " threads changed the file";
        std::filesystem::remove(parallel);
    }
    std::filesystem::remove(inOrder);
    std::filesystem::remove(shuffled);
}

// A killed run's ray database goes on from the writer's last mark: the partial file, which
// may hold chunks past the mark, is cut back to it, the rays from the mark on are added again
// (those below it, added again too, are ignored), and it closes to the bytes of the run that
// was not stopped. A partial file of another run, or one shorter than the mark, is refused.
TEST(RayDatabase, AResumedWriterFinishesTheSameFile) {
    const RayDatabaseInfo info = testInfo();
    const uint64_t n = 2000;
    const auto straight = tempFile("straight");
    writeRays(straight, iota(n), smallChunks(), info);
    const std::vector<uint8_t> reference = readBytes(straight);
    auto put = [](RayDatabaseWriter& w, uint64_t ray) {
        if (ray % 7 == 3) {
            w.skip(ray);
        } else {
            w.add(ray, randomHistory(2024, ray, 150));
        }
    };
    const auto path = tempFile("killed");
    std::filesystem::path partial = path;
    partial += ".partial";
    RayDatabaseMark mark;
    std::vector<uint8_t> onDisk;
    {
        RayDatabaseWriter w(path, info, smallChunks());
        EXPECT_EQ(w.mark().nextRay, 0u);
        for (uint64_t ray = 0; ray < 1200; ++ray) put(w, ray);
        w.flush();
        mark = w.mark();
        for (uint64_t ray = 1200; ray < 1500; ++ray) put(w, ray);
        w.flush();
        onDisk = readBytes(partial);
    }  // not closed: as a killed run leaves it, but for the file, which is put back below
    ASSERT_GT(mark.summary.chunks, 2u);
    EXPECT_GT(mark.nextRay, 900u);
    EXPECT_LT(mark.nextRay, 1200u);
    ASSERT_GT(onDisk.size(), mark.bytes);  // chunks past the mark
    EXPECT_TRUE(std::equal(onDisk.begin(), onDisk.begin() + static_cast<std::ptrdiff_t>(mark.bytes),
                           reference.begin()));
    writeBytes(partial, onDisk);
    {
        RayDatabaseWriter w(path, info, smallChunks(), mark);
        EXPECT_EQ(w.mark(), mark);
        for (uint64_t ray = mark.nextRay - 100; ray < n; ++ray) put(w, ray);
        w.close();
    }
    EXPECT_TRUE(readBytes(path) == reference) << "the resumed file differs";
    EXPECT_FALSE(std::filesystem::exists(partial));

    // Another run's partial file (another seed in its header), or one cut short.
    writeBytes(partial, onDisk);
    RayDatabaseInfo other = info;
    other.seed = 43;
    EXPECT_THROW(RayDatabaseWriter(path, other, smallChunks(), mark), RayDatabaseError);
    EXPECT_TRUE(std::filesystem::exists(partial));  // a refused resume leaves the file
    onDisk.resize(mark.bytes - 1);
    writeBytes(partial, onDisk);
    try {
        RayDatabaseWriter w(path, info, smallChunks(), mark);
        ADD_FAILURE() << "a partial file shorter than the mark was taken";
    } catch (const RayDatabaseError& e) {
        EXPECT_NE(std::string(e.what()).find("not the " + std::to_string(mark.bytes) +
                                             " the run had written"),
                  std::string::npos)
            << e.what();
    }
    std::filesystem::remove(partial);
    std::filesystem::remove(path);
    std::filesystem::remove(straight);
}

TEST(RayDatabase, SeekRayContinuesAtTheFirstStoredRayAtOrAfter) {
    const auto p = tempFile("seek");
    writeRays(p, iota(1200), smallChunks(), testInfo());
    RayDatabaseReader r(p);
    RayRecord rec;
    for (uint64_t target : {0ull, 1ull, 3ull, 500ull, 514ull, 1199ull}) {
        r.seekRay(target);
        ASSERT_TRUE(r.next(rec)) << target;
        const uint64_t expected = target % 7 == 3 ? target + 1 : target;
        EXPECT_EQ(rec.rayIndex, expected);
        expectStored(randomHistory(2024, expected, 150), rec.history, r.info().encoding);
    }
    r.seekRay(5000);
    EXPECT_FALSE(r.next(rec));
    std::filesystem::remove(p);
}

TEST(RayDatabase, WriterRejectsMisuseAndLeavesNoFileWithoutClose) {
    const auto p = tempFile("misuse");
    const RayDatabaseInfo info = testInfo();
    {
        RayDatabaseWriter w(p, info);
        w.add(0, randomHistory(1, 0, 20));
        EXPECT_TRUE(std::filesystem::exists(p.string() + ".partial"));
        PathHistory bad = randomHistory(1, 1, 20);
        PathNode n;
        n.type = EventType::Exit;
        n.object = 41;  // the table has 41 objects
        bad.append(0, n);
        EXPECT_THROW(w.add(1, bad), std::invalid_argument);
        w.add(1, randomHistory(1, 1, 20));
        w.flush();
        EXPECT_THROW(
            {
                w.add(1, randomHistory(1, 1, 20));
                w.flush();
            },
            std::invalid_argument);
    }  // destroyed without close()
    EXPECT_FALSE(std::filesystem::exists(p));
    EXPECT_FALSE(std::filesystem::exists(p.string() + ".partial"));

    RayDatabaseInfo wrongUnit = info;
    wrongUnit.fluxUnit = "W/sr";
    EXPECT_THROW(RayDatabaseWriter(p, wrongUnit), std::invalid_argument);
    EXPECT_THROW(RayDatabaseWriter("/nonexistent-dir/x.vrdb", info), RayDatabaseError);

    // Rays may have gaps: they are written in order at close(), and the emitted count is
    // what the tracer says, or at least the highest ray plus one.
    {
        RayDatabaseWriter w(p, info);
        w.add(10, randomHistory(1, 10, 20));
        w.add(4, randomHistory(1, 4, 20));
        w.setEmittedRays(100);
        EXPECT_EQ(w.close().emittedRays, 100u);
    }
    RayDatabaseReader r(p);
    RayRecord rec;
    ASSERT_TRUE(r.next(rec));
    EXPECT_EQ(rec.rayIndex, 4u);
    ASSERT_TRUE(r.next(rec));
    EXPECT_EQ(rec.rayIndex, 10u);
    EXPECT_FALSE(r.next(rec));
    std::filesystem::remove(p);
}

TEST(RayDatabase, EmptyRunIsAValidFile) {
    const auto p = tempFile("empty");
    RayDatabaseWriter w(p, RayDatabaseInfo{});
    const RayDatabaseSummary s = w.close();
    EXPECT_EQ(s, RayDatabaseSummary{});
    RayDatabaseReader r(p);
    RayRecord rec;
    EXPECT_FALSE(r.next(rec));
    EXPECT_EQ(r.info(), RayDatabaseInfo{});
    std::filesystem::remove(p);
}

// A small file with several chunks, the damage tests' subject.
struct Damaged {
    std::filesystem::path good = tempFile("good"), bad = tempFile("bad");
    std::vector<uint8_t> bytes;
    std::vector<RayDatabaseChunk> chunks;
    uint64_t headerSize = 0, indexOffset = 0;

    Damaged() {
        RayDatabaseOptions o;
        o.chunkBytes = 4096;
        writeRays(good, iota(200), o, testInfo());
        bytes = readBytes(good);
        RayDatabaseReader r(good);
        chunks = r.chunks();
        headerSize = chunks.front().offset;
        indexOffset = bytes.size() - 56 - (8 + 20 * chunks.size() + 4);
    }
    ~Damaged() {
        std::filesystem::remove(good);
        std::filesystem::remove(bad);
    }
    // Opens `b` and reads it through; the error, or none.
    std::optional<RayDatabaseError> read(const std::vector<uint8_t>& b) const {
        writeBytes(bad, b);
        try {
            RayDatabaseReader r(bad);
            RayRecord rec;
            while (r.next(rec)) {
            }
        } catch (const RayDatabaseError& e) {
            return e;
        }
        return std::nullopt;
    }
    std::vector<uint8_t> truncated(uint64_t n) const {
        return std::vector<uint8_t>(bytes.begin(), bytes.begin() + static_cast<long>(n));
    }
};

bool contains(const RayDatabaseError& e, const std::string& s) {
    return e.message().find(s) != std::string::npos;
}

TEST(RayDatabase, TruncatedFilesNameWhereTheDataEnds) {
    const Damaged d;
    ASSERT_GE(d.chunks.size(), 4u);
    // Every cut fails, at an offset no later than the cut, and the message names the file.
    for (uint64_t n = 0; n < d.bytes.size(); n += (n < d.headerSize + 64 ? 1 : 61)) {
        const auto e = d.read(d.truncated(n));
        ASSERT_TRUE(e.has_value()) << "cut at " << n;
        EXPECT_LE(e->offset(), n) << "cut at " << n << ": " << e->what();
        EXPECT_EQ(e->path(), d.bad);
        EXPECT_NE(std::string(e->what()).find(d.bad.string()), std::string::npos);
        EXPECT_TRUE(contains(*e, "truncated")) << "cut at " << n << ": " << e->what();
    }
    // Inside the header.
    auto e = d.read(d.truncated(d.headerSize - 3));
    EXPECT_EQ(e->offset(), d.headerSize - 3);
    EXPECT_TRUE(contains(*e, "in the header")) << e->what();
    // Inside chunk 2: the offset of chunk 2.
    e = d.read(d.truncated(d.chunks[2].offset + 100));
    EXPECT_EQ(e->offset(), d.chunks[2].offset) << e->what();
    EXPECT_TRUE(contains(*e, "chunk 2")) << e->what();
    // Right after the last chunk: no index, no end block.
    e = d.read(d.truncated(d.indexOffset));
    EXPECT_EQ(e->offset(), d.indexOffset) << e->what();
    EXPECT_TRUE(contains(*e, std::to_string(d.chunks.size()) + " complete chunks")) << e->what();
    // Inside the index, and inside the end block.
    e = d.read(d.truncated(d.indexOffset + 9));
    EXPECT_EQ(e->offset(), d.indexOffset) << e->what();
    EXPECT_TRUE(contains(*e, "chunk index")) << e->what();
    e = d.read(d.truncated(d.bytes.size() - 1));
    EXPECT_EQ(e->offset(), d.bytes.size() - 56) << e->what();
    EXPECT_TRUE(contains(*e, "end block")) << e->what();
}

TEST(RayDatabase, CorruptFilesNameTheDamagedBlock) {
    const Damaged d;
    ASSERT_FALSE(d.read(d.bytes).has_value());
    auto flipped = [&](uint64_t at) {
        std::vector<uint8_t> b = d.bytes;
        b[at] ^= 0x5a;
        return b;
    };
    auto e = d.read(flipped(0));
    EXPECT_EQ(e->offset(), 0u);
    EXPECT_TRUE(contains(*e, "not a veil ray database")) << e->what();
    e = d.read(flipped(8));
    EXPECT_EQ(e->offset(), 8u);
    EXPECT_TRUE(contains(*e, "version")) << e->what();
    e = d.read(flipped(50));  // inside the scene name
    EXPECT_EQ(e->offset(), 0u);
    EXPECT_TRUE(contains(*e, "header checksum")) << e->what();
    e = d.read(flipped(d.chunks[1].offset + 24 + 10));  // chunk 1's payload
    EXPECT_EQ(e->offset(), d.chunks[1].offset);
    EXPECT_TRUE(contains(*e, "chunk 1: checksum mismatch")) << e->what();
    e = d.read(flipped(d.chunks[3].offset + 1));  // chunk 3's magic
    EXPECT_EQ(e->offset(), d.chunks[3].offset);
    EXPECT_TRUE(contains(*e, "chunk 3")) << e->what();
    e = d.read(flipped(d.indexOffset + 12));
    EXPECT_EQ(e->offset(), d.indexOffset);
    EXPECT_TRUE(contains(*e, "index")) << e->what();
    e = d.read(flipped(d.bytes.size() - 20));
    EXPECT_EQ(e->offset(), d.bytes.size() - 56);
    EXPECT_TRUE(contains(*e, "end block checksum")) << e->what();
}

// Damage behind a valid checksum (as a writer bug would leave it) is found by the decoder,
// at the exact byte.
TEST(RayDatabase, DecodeErrorsBehindAValidChecksumGiveTheExactByte) {
    const Damaged d;
    auto withFixedCrc = [&](size_t chunk, uint64_t at, uint8_t value) {
        std::vector<uint8_t> b = d.bytes;
        b[at] = value;
        const uint64_t payload = d.chunks[chunk].offset + 24;
        const uint32_t size = b[d.chunks[chunk].offset + 4] | b[d.chunks[chunk].offset + 5] << 8 |
                              b[d.chunks[chunk].offset + 6] << 16 |
                              uint32_t(b[d.chunks[chunk].offset + 7]) << 24;
        const uint32_t crc = crc32(b.data() + payload, size);
        for (int i = 0; i < 4; ++i) b[d.chunks[chunk].offset + 20 + i] = uint8_t(crc >> (8 * i));
        return b;
    };
    // Chunk 0's first record: ray delta (1 byte), wavelength (4), event count (a varint of
    // 1 or 2 bytes), then the Emit tag.
    const PathHistory first = randomHistory(2024, 0, 150);
    const uint64_t tagAt = d.chunks[0].offset + 24 + 1 + 4 + (first.size() < 128 ? 1 : 2);
    auto e = d.read(withFixedCrc(0, tagAt, 0x0e));
    ASSERT_TRUE(e.has_value());
    EXPECT_EQ(e->offset(), tagAt) << e->what();
    EXPECT_TRUE(contains(*e, "invalid event type 14")) << e->what();
    // The Emit's source id (the next byte) outside the source table: the record's offset.
    e = d.read(withFixedCrc(0, tagAt + 1, 9));
    ASSERT_TRUE(e.has_value());
    EXPECT_EQ(e->offset(), d.chunks[0].offset + 24) << e->what();
    EXPECT_TRUE(contains(*e, "source 8 outside the source table")) << e->what();

    // Random damage behind valid checksums never crashes the reader: it reads or throws
    // RayDatabaseError.
    CounterRng rng(5, 0);
    const uint64_t payload = d.chunks[1].offset + 24;
    const uint64_t size = d.chunks[2].offset - payload;
    int errors = 0;
    for (int trial = 0; trial < 300; ++trial) {
        const uint64_t at = payload + static_cast<uint64_t>(rng.uniform() * size);
        const auto err = d.read(withFixedCrc(1, at, uint8_t(rng.uniform() * 256)));
        if (err) {
            ++errors;
            EXPECT_GE(err->offset(), d.chunks[1].offset);
            // At most at the next chunk, which a wrong last ray index puts out of order.
            EXPECT_LE(err->offset(), d.chunks[2].offset) << err->what();
        }
    }
    EXPECT_GT(errors, 0);
}

TEST(RayDatabase, DescribeSceneTakesNamesAndMediaFromTheScene) {
    Scene scene;
    SceneObject front;
    front.mediumBack = scene.addMedium({"N-BK7", Material::catalog("N-BK7")});
    front.name = "L1.front";
    front.kind = ObjectKind::LensFace;
    front.part = "L1";
    front.property = "uncoated";
    scene.addObject(front);
    SceneObject barrel;
    barrel.name = "barrel";
    barrel.aliases = {"housing"};
    barrel.kind = ObjectKind::Mechanics;
    scene.addObject(barrel);
    const RayDatabaseInfo info = describeScene(scene, "one lens");
    EXPECT_EQ(info.sceneName, "one lens");
    ASSERT_EQ(info.objects.size(), 2u);
    EXPECT_EQ(info.objects[0],
              (RayDatabaseObject{"L1.front", ObjectKind::LensFace, "L1", "uncoated", {}}));
    EXPECT_EQ(info.objects[1].aliases, std::vector<std::string>{"housing"});
    EXPECT_EQ(info.media, (std::vector<std::string>{"air", "N-BK7"}));
    // The hash follows the names.
    Scene renamed;
    renamed.addMedium({"N-BK7", Material::catalog("N-BK7")});
    front.name = "L1.front2";
    renamed.addObject(front);
    renamed.addObject(barrel);
    EXPECT_NE(describeScene(renamed, "one lens").sceneHash, info.sceneHash);
    EXPECT_EQ(describeScene(scene, "other name").sceneHash, info.sceneHash);
}

}  // namespace
}  // namespace veil
