#include "analysis/runs/trace_checkpoint.h"

#include <cstring>
#include <fstream>
#include <limits>

#include "analysis/criteria/criterion_images.h"
#include "lensdata/errors.h"
#include "lensdata/output_file.h"

namespace veil {

namespace {

constexpr char kMagic[8] = {'V', 'E', 'I', 'L', 'T', 'C', 'K', 'P'};
constexpr uint32_t kVersion = 1;

template <class T>
void put(std::ostream& os, const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    os.write(reinterpret_cast<const char*>(&v), sizeof(T));
}
template <class T>
void putVector(std::ostream& os, const std::vector<T>& v) {
    put(os, static_cast<uint64_t>(v.size()));
    os.write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * sizeof(T)));
}
void putImage(std::ostream& os, const DetectorImage& s) {
    putVector(os, s.fluxes());
    putVector(os, s.fluxesSquared());
    putVector(os, s.counts());
    put(os, s.totalFlux());
    put(os, s.totalFluxSquared());
    put(os, s.totalCount());
}

class Reader {
  public:
    explicit Reader(const std::filesystem::path& path) : path_(path), is_(path, std::ios::binary) {
        if (!is_) fail("cannot be read: " + systemReason());
        std::error_code ec;
        size_ = std::filesystem::file_size(path, ec);
        if (ec) fail("cannot be read: " + ec.message());
    }
    uint64_t size() const { return size_; }
    [[noreturn]] void fail(const std::string& why) const {
        throw ParseError({"--resume", 0, 0}, path_.string() + ": " + why);
    }
    template <class T>
    T get() {
        T v{};
        is_.read(reinterpret_cast<char*>(&v), sizeof(T));
        if (!is_) fail("ends early: the checkpoint is damaged");
        return v;
    }
    template <class T>
    std::vector<T> getVector(uint64_t expected) {
        if (get<uint64_t>() != expected) fail("its images are not this run's");
        std::vector<T> v(expected);
        is_.read(reinterpret_cast<char*>(v.data()), std::streamsize(expected * sizeof(T)));
        if (!is_) fail("ends early: the checkpoint is damaged");
        return v;
    }
    DetectorImage getImage(const DetectorImage& like) {
        const auto n = static_cast<uint64_t>(like.geometry().pixelCount());
        std::vector<double> flux = getVector<double>(n), flux2 = getVector<double>(n);
        std::vector<uint64_t> counts = getVector<uint64_t>(n);
        const double total = get<double>(), total2 = get<double>();
        const uint64_t count = get<uint64_t>();
        return DetectorImage::fromSums(like.geometry(), std::move(flux), std::move(flux2),
                                       std::move(counts), total, total2, count);
    }
    bool atEnd() { return is_.peek() == std::char_traits<char>::eof(); }
    std::istream& stream() { return is_; }

  private:
    std::filesystem::path path_;
    std::ifstream is_;
    uint64_t size_ = 0;
};

}  // namespace

void writeTraceCheckpoint(const std::filesystem::path& path, uint64_t fingerprint, uint64_t added,
                          const FluxBudget& budget, const std::vector<DetectorImage>& images,
                          const CriterionImages* layers, const ConsumerMark* consumer) {
    const std::filesystem::path tmp = temporaryFor(path);
    {
        errno = 0;
        std::ofstream os(tmp, std::ios::binary | std::ios::trunc);
        if (!os)
            throw std::runtime_error(tmp.string() +
                                     ": cannot write the checkpoint: " + systemReason());
        os.write(kMagic, sizeof kMagic);
        put(os, kVersion);
        put(os, fingerprint);
        put(os, added);
        put(os, budget);
        put(os, static_cast<uint64_t>(images.size()));
        for (const DetectorImage& d : images) putImage(os, d);
        put(os, static_cast<uint8_t>(layers != nullptr));
        if (layers)
            layers->withState([&](uint64_t next, const std::vector<std::vector<DetectorImage>>& l) {
                put(os, next);
                put(os, static_cast<uint64_t>(l.size()));
                for (const std::vector<DetectorImage>& layer : l)
                    for (const DetectorImage& d : layer) putImage(os, d);
            });
        put(os, static_cast<uint8_t>(consumer != nullptr));
        if (consumer) {
            put(os, consumer->nextRay);
            put(os, static_cast<uint64_t>(consumer->bytes.size()));
            os.write(consumer->bytes.data(), std::streamsize(consumer->bytes.size()));
        }
        os.write(kMagic, sizeof kMagic);  // the end: a file cut short is seen as such
        os.flush();
        if (!os) {
            const std::string reason = systemReason();
            removeQuietly(tmp);
            throw std::runtime_error(tmp.string() + ": writing the checkpoint failed: " + reason);
        }
    }
    commitFile(tmp, path);
}

TraceCheckpoint readTraceCheckpoint(const std::filesystem::path& path, uint64_t fingerprint,
                                    const std::vector<DetectorImage>& templates,
                                    size_t layerCount) {
    Reader r(path);
    char magic[sizeof kMagic];
    r.stream().read(magic, sizeof magic);
    if (!r.stream() || std::memcmp(magic, kMagic, sizeof kMagic) != 0)
        r.fail("is not a veil trace checkpoint");
    if (r.get<uint32_t>() != kVersion) r.fail("is a checkpoint of another veil version");
    if (r.get<uint64_t>() != fingerprint)
        r.fail(
            "belongs to another run: the scene, the rays, the seed, the transport options, "
            "--where, --prune and --save-rays must be those of the run it continues");
    TraceCheckpoint c;
    c.added = r.get<uint64_t>();
    c.budget = r.get<FluxBudget>();
    if (r.get<uint64_t>() != templates.size()) r.fail("its detectors are not this run's");
    for (const DetectorImage& t : templates) c.images.push_back(r.getImage(t));
    c.hasLayers = r.get<uint8_t>() != 0;
    if (c.hasLayers != (layerCount > 0)) r.fail("its criterion layers are not this run's");
    if (c.hasLayers) {
        c.layersNextRay = r.get<uint64_t>();
        if (r.get<uint64_t>() != layerCount) r.fail("its criterion layers are not this run's");
        c.layers.resize(layerCount);
        for (std::vector<DetectorImage>& layer : c.layers)
            for (const DetectorImage& t : templates) layer.push_back(r.getImage(t));
    }
    c.hasConsumer = r.get<uint8_t>() != 0;
    if (c.hasConsumer) {
        c.consumer.nextRay = r.get<uint64_t>();
        const uint64_t n = r.get<uint64_t>();
        if (n > r.size()) r.fail("is damaged (a length past its end)");
        c.consumer.bytes.resize(n);
        r.stream().read(c.consumer.bytes.data(), std::streamsize(n));
    }
    r.stream().read(magic, sizeof magic);
    if (!r.stream() || std::memcmp(magic, kMagic, sizeof kMagic) != 0 || !r.atEnd())
        r.fail("ends early or goes on past its end: the checkpoint is damaged");
    return c;
}

}  // namespace veil
