// libFuzzer target: a ray database (.vrdb, tracer/records/ray_database.h), opened and read through.
#include "fuzz/fuzz_common.h"
#include "tracer/records/ray_database.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const auto path = veil::fuzz::writeScratch("input.vrdb", veil::fuzz::asText(data, size));
    try {
        veil::RayDatabaseReader reader(path);
        veil::RayRecord record;
        while (reader.next(record)) {
        }
    } catch (const veil::RayDatabaseError&) {
    }
    return 0;
}
