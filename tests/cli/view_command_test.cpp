// veil view as a user runs it: one HTML page that holds the scene (every object under its
// own name, each lens face out to its clear semi-diameter), the selected ray paths as `paths`
// selects them, three.js inlined and nothing to fetch; the same seed gives the same page; bad
// input stops before anything is written. In a real headless Chromium (Debian's chromium,
// skipped with a message where it is absent) the page draws its first frame with every object
// and the screenshot is not blank.

#include <cairo.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "tests/cli/run_veil.h"

namespace {

namespace fs = std::filesystem;

std::string dirFor(const std::string& what) {
    const std::string d = ::testing::TempDir() + "veil_view_" + what;
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

std::vector<uint8_t> unbase64(const std::string& s) {
    auto value = [](char c) -> int {
        if (c >= 'A' && c <= 'Z') return c - 'A';
        if (c >= 'a' && c <= 'z') return c - 'a' + 26;
        if (c >= '0' && c <= '9') return c - '0' + 52;
        if (c == '+') return 62;
        if (c == '/') return 63;
        return -1;
    };
    std::vector<uint8_t> out;
    uint32_t acc = 0;
    int bits = 0;
    for (char c : s) {
        const int v = value(c);
        if (v < 0) continue;  // padding
        acc = (acc << 6) | static_cast<uint32_t>(v);
        bits += 6;
        if (bits >= 8) {
            bits -= 8;
            out.push_back(static_cast<uint8_t>((acc >> bits) & 0xFF));
        }
    }
    return out;
}

template <class T>
std::vector<T> decode(const nlohmann::json& text) {
    const std::vector<uint8_t> bytes = unbase64(text.get<std::string>());
    EXPECT_EQ(bytes.size() % sizeof(T), 0u);
    std::vector<T> out(bytes.size() / sizeof(T));
    std::memcpy(out.data(), bytes.data(), out.size() * sizeof(T));
    return out;
}

// The data the page carries, as the page reads it.
nlohmann::json pageData(const std::string& html) {
    const std::string open = "<script type=\"application/json\" id=\"veil-data\">";
    const size_t begin = html.find(open);
    if (begin == std::string::npos) return {};
    const size_t from = begin + open.size();
    const size_t end = html.find("</script>", from);
    return nlohmann::json::parse(html.substr(from, end - from));
}

const std::string kDoubleGauss = "examples/scenes/double_gauss_50mm.toml";

TEST(ViewCommand, OnePageHoldsEveryObjectAndFetchesNothing) {
    const std::string dir = dirFor("scene");
    // A beam 10 degrees off axis, as trace and paths add it.
    const VeilRun r =
        runVeil("view " + kDoubleGauss + " --field 0,10 --json -o " + dir + "/scene.html");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json report = nlohmann::json::parse(r.out);
    const std::string html = readText(dir + "/scene.html");
    // Nothing fetched: no script or stylesheet by reference, three.js inlined.
    EXPECT_EQ(html.find("<script src"), std::string::npos);
    EXPECT_EQ(html.find("<link"), std::string::npos);
    EXPECT_EQ(html.find("url(http"), std::string::npos);
    EXPECT_NE(html.find("OrbitControls"), std::string::npos);
    EXPECT_NE(html.find("WebGLRenderer"), std::string::npos);

    const nlohmann::json data = pageData(html);
    ASSERT_TRUE(data.is_object());
    EXPECT_FALSE(data.contains("paths"));
    // Every object the export writes (dummies have no triangles) is in the page by name.
    const VeilRun exp = runVeil("export " + kDoubleGauss + " --chord-tolerance 0.05 --json -o " +
                                dir + "/scene.ply");
    ASSERT_EQ(exp.exitCode, 0) << exp.err;
    std::set<std::string> names;
    size_t triangles = 0, grids = 0;
    for (const nlohmann::json& o : data["objects"]) {
        names.insert(o["name"].get<std::string>());
        const auto positions = decode<float>(o["positions"]);
        const auto indices = decode<uint32_t>(o["indices"]);
        ASSERT_EQ(indices.size(), 3 * o["triangles"].get<size_t>()) << o["name"];
        for (uint32_t i : indices) ASSERT_LT(3 * i + 2, positions.size()) << o["name"];
        if (o["kind"] == "detector") {
            // The detector's grid, the area that records light: a rectangle of two triangles
            // on its sensor surface, which is drawn pale.
            ++grids;
            EXPECT_EQ(o["triangles"].get<size_t>(), 2u);
            ASSERT_EQ(positions.size(), 12u);
            const double dx = std::abs(positions[3] - positions[0]),
                         dy = std::abs(positions[7] - positions[4]);
            EXPECT_GT(dx, 1.0);
            EXPECT_GT(dy, 1.0);
            continue;
        }
        if (o["name"] == "sensor") {
            EXPECT_EQ(o["kind"], "sensor surface");
        }
        triangles += o["triangles"].get<size_t>();
    }
    EXPECT_EQ(grids, 1u);
    EXPECT_EQ(triangles, nlohmann::json::parse(exp.out)["triangles"].get<size_t>());
    EXPECT_EQ(report["triangles"].get<size_t>(), triangles + 2 * grids);
    for (const char* n : {"L1.front", "L1.edge", "stop", "barrel", "sensor"})
        EXPECT_EQ(names.count(n), 1u) << n;

    // Each lens face between glass and air reaches its clear semi-diameter (veil info), no
    // farther: its polygon's vertices lie on the rim. (A cemented face runs on to where the
    // two elements' flats meet.)
    const VeilRun info = runVeil("info " + kDoubleGauss + " --json");
    ASSERT_EQ(info.exitCode, 0) << info.err;
    const nlohmann::json lens = nlohmann::json::parse(info.out);
    int faces = 0;
    std::string before = "AIR";
    for (const nlohmann::json& s : lens["surfaces"]) {
        const std::string name = s["name"].get<std::string>();
        const bool cemented = before != "AIR" && s["material"] != "AIR";
        before = s["material"].get<std::string>();
        if (cemented) continue;
        for (const nlohmann::json& o : data["objects"]) {
            if (o["name"] != name || o["kind"] != "lens") continue;
            const auto p = decode<float>(o["positions"]);
            double rim = 0.0;
            for (size_t k = 0; k + 2 < p.size(); k += 3)
                rim = std::max(rim, std::hypot(double(p[k]), double(p[k + 1])));
            EXPECT_NEAR(rim, s["clear_semi_diameter_mm"].get<double>(), 1e-5) << name;
            ++faces;
        }
    }
    EXPECT_EQ(faces, 8);  // 6 elements, two of them cemented pairs: 8 faces in air

    // The beam starts in front of the lens and runs 10 degrees off axis: tan(10 deg) in y.
    ASSERT_EQ(data["sources"].size(), 1u);
    ASSERT_EQ(report["sources"].get<size_t>(), 1u);
    const nlohmann::json& beam = data["sources"][0];
    const double dy = beam["direction"][1].get<double>(), dz = beam["direction"][2].get<double>();
    EXPECT_NEAR(dy / dz, std::tan(10.0 * M_PI / 180.0), 1e-9);
    EXPECT_LT(beam["position"][2].get<double>(), 0.0);
    EXPECT_EQ(decode<float>(beam["rays"]).size(), 6 * beam["ray_count"].get<size_t>());
}

TEST(ViewCommand, PathsAreTheSelectionOfVeilPathsAndTheSameSeedGivesTheSamePage) {
    const std::string dir = dirFor("paths");
    const std::string where = "seq(fresnel(L4.*), fresnel(L3.*), hit(sensor))";
    const std::string args =
        " --where '" + where + "' --first 10 --batch 2k -n 20k --seed 3 --quiet";
    const VeilRun a = runVeil("view " + kDoubleGauss + args + " --json -o " + dir + "/a.html");
    ASSERT_EQ(a.exitCode, 0) << a.err;
    const VeilRun b = runVeil("view " + kDoubleGauss + args + " -o " + dir + "/b.html");
    ASSERT_EQ(b.exitCode, 0) << b.err;
    EXPECT_EQ(readText(dir + "/a.html"), readText(dir + "/b.html"));
    const VeilRun p = runVeil("paths " + kDoubleGauss + args + " --json -o " + dir + "/paths");
    ASSERT_EQ(p.exitCode, 0) << p.err;
    const nlohmann::json report = nlohmann::json::parse(a.out);
    const nlohmann::json paths = nlohmann::json::parse(p.out);
    EXPECT_EQ(report["rays_found"], paths["found"]);
    EXPECT_EQ(report["paths_drawn"], paths["paths_drawn"]);
    EXPECT_EQ(report["rays_traced"], paths["rays_traced"]);
    EXPECT_EQ(report["rays_found"].get<int>(), 10);

    const nlohmann::json data = pageData(readText(dir + "/a.html"));
    ASSERT_TRUE(data.contains("paths"));
    const nlohmann::json& d = data["paths"];
    EXPECT_EQ(d["count"], paths["paths_drawn"]);
    const size_t segments = d["segments"].get<size_t>();
    EXPECT_GT(segments, 10u * 8);  // a ghost path crosses the lens three times
    EXPECT_EQ(decode<float>(d["positions"]).size(), 6 * segments);
    EXPECT_EQ(unbase64(d["colors"].get<std::string>()).size(), 6 * segments);
    EXPECT_EQ(decode<uint32_t>(d["ray_of_segment"]).size(), segments);
    const auto logFlux = decode<float>(d["log10_flux_of_segment"]);
    ASSERT_EQ(logFlux.size(), segments);
    // Weak segments first; the strongest is the legend's maximum.
    for (size_t k = 1; k < segments; ++k) ASSERT_LE(logFlux[k - 1], logFlux[k]);
    EXPECT_NEAR(std::pow(10.0, logFlux.back()), d["legend"]["max"].get<double>(),
                1e-5 * d["legend"]["max"].get<double>());
}

TEST(ViewCommand, BadInputStopsBeforeAnythingIsWritten) {
    const std::string dir = dirFor("bad");
    const std::string page = dir + "/scene.html";
    // An option's bad value exits 2 (a bad command line), a missing package 1.
    struct Case {
        std::string args, env, message;
        int exitCode;
    };
    const Case cases[] = {
        {"view " + kDoubleGauss + " -o " + page, "VEIL_THREE_JS_DIR=/nonexistent", "libjs-three",
         1},
        {"view " + kDoubleGauss + " --where 'hit(nothing)' -o " + page, "", "nothing", 2},
        {"view " + kDoubleGauss + " --colour event -o " + page, "", "give --where too", 2},
        {"view " + kDoubleGauss + " -o " + dir, "", "is a folder", 2},
        {"view " + kDoubleGauss + " -o /proc/x/scene.html", "", "-o /proc/x/scene.html", 2},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.args);
        const VeilRun r = runVeil(c.args, c.env);
        EXPECT_EQ(r.exitCode, c.exitCode) << r.err;
        EXPECT_NE(r.err.find(c.message), std::string::npos) << r.err;
        EXPECT_FALSE(fs::exists(page));
    }
}

// The first frame in Chromium: every object drawn, the screenshot not blank.
TEST(ViewInChromium, TheFirstFrameShowsEveryObject) {
    if (!fs::exists("/usr/bin/chromium"))
        GTEST_SKIP() << "Chromium is not installed (Debian package chromium): the page is not "
                        "opened in a browser";
    const std::string dir = dirFor("chromium");
    const VeilRun r =
        runVeil("view " + kDoubleGauss +
                " --where 'seq(fresnel(L4.*), fresnel(L3.*), hit(sensor))' --first 10 --batch 2k "
                "--json -o " +
                dir + "/scene.html");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json report = nlohmann::json::parse(r.out);
    const std::string flags =
        "--headless=new --no-sandbox --use-angle=swiftshader --enable-unsafe-swiftshader "
        "--hide-scrollbars --window-size=1280,800 --virtual-time-budget=15000 ";
    const std::string url = "file://" + fs::absolute(dir + "/scene.html").string();
    const std::string domFile = dir + "/dom.html";
    ASSERT_EQ(std::system(("/usr/bin/chromium " + flags + "--dump-dom " + url + " > " + domFile +
                           " 2>/dev/null")
                              .c_str()),
              0);
    const std::string dom = readText(domFile);
    EXPECT_NE(dom.find("data-veil-ready=\"1\""), std::string::npos) << dom.substr(0, 2000);
    EXPECT_EQ(dom.find("data-veil-error=\""), std::string::npos) << dom.substr(0, 2000);
    EXPECT_NE(
        dom.find("data-veil-objects=\"" + std::to_string(report["objects"].get<int>()) + "\""),
        std::string::npos);
    EXPECT_NE(
        dom.find("data-veil-paths=\"" + std::to_string(report["paths_drawn"].get<int>()) + "\""),
        std::string::npos);

    const std::string shot = dir + "/shot.png";
    ASSERT_EQ(std::system(("/usr/bin/chromium " + flags + "--screenshot=" + shot + " " + url +
                           " > /dev/null 2>&1")
                              .c_str()),
              0);
    cairo_surface_t* s = cairo_image_surface_create_from_png(shot.c_str());
    ASSERT_EQ(cairo_surface_status(s), CAIRO_STATUS_SUCCESS) << shot;
    const int w = cairo_image_surface_get_width(s), h = cairo_image_surface_get_height(s);
    const int stride = cairo_image_surface_get_stride(s);
    const unsigned char* px = cairo_image_surface_get_data(s);
    // Not blank: many distinct colours (shaded glass, metal, coloured rays), not a flat page.
    std::set<uint32_t> colours;
    for (int y = 0; y < h; y += 2)
        for (int x = 0; x < w; x += 2) {
            uint32_t v;
            std::memcpy(&v, px + y * stride + 4 * x, 4);
            colours.insert(v & 0xF0F0F0u);  // 4 bits per channel
        }
    cairo_surface_destroy(s);
    EXPECT_EQ(w, 1280);
    EXPECT_GT(colours.size(), 200u);
}

}  // namespace
