// The [mechanics] table of a scene file read into a MechanicsSpec (keys and defaults:
// mechanics.cpp's header and docs/format.md).

#include <algorithm>
#include <optional>
#include <string>
#include <string_view>

#include "geometry/mechanics.h"
#include "geometry/mechanics_builder.h"
#include "geometry/revolve.h"
#include "lensdata/toml_document.h"

namespace veil {

using mechanics_detail::fmt;

// Reading [mechanics]

namespace {

// A part given as `key = false`, `key = true` or `key = { ... }`. Returns the table when
// there is one; `enabled` is set from the boolean or the table's `enabled` key.
std::optional<TomlTable> partTable(const TomlTable& m, std::string_view key, bool& enabled) {
    const auto v = m.get(key);
    if (!v) return std::nullopt;
    if (v->isBool()) {
        enabled = v->asBool();
        return std::nullopt;
    }
    if (!v->isTable()) v->failExpected("a table or a boolean");
    TomlTable t = v->asTable();
    enabled = t.boolean("enabled", true);
    return t;
}

}  // namespace

MechanicsSpec readMechanicsTable(const TomlTable& m) {
    MechanicsSpec s;
    const NumberRange positive = NumberRange::above(0.0);
    s.chordToleranceMm = m.number("chord_tolerance_mm", s.chordToleranceMm, positive);
    s.contactGapMm = m.number("contact_gap_mm", s.contactGapMm, positive);
    s.property = m.string("property");
    if (const auto v = m.get("lens_edges")) {
        const TomlTable t = v->asTable();
        s.lensEdgeProperty = t.string("property");
    }

    if (const auto t = partTable(m, "barrel", s.barrel.enabled)) {
        s.barrel.wallMm = t->number("wall_mm", s.barrel.wallMm, positive);
        s.barrel.clearanceMm = t->number("clearance_mm", s.barrel.clearanceMm, positive);
        s.barrel.property = t->string("property");
    }
    if (const auto t = partTable(m, "retainers", s.retainers.enabled)) {
        s.retainers.widthMm = t->number("width_mm", s.retainers.widthMm, positive);
        s.retainers.property = t->string("property");
    }
    if (const auto t = partTable(m, "spacers", s.spacers.enabled)) {
        s.spacers.minLengthMm =
            t->number("min_length_mm", s.spacers.minLengthMm, NumberRange::atLeast(0.0));
        s.spacers.property = t->string("property");
    }
    if (const auto t = partTable(m, "stop", s.stop.enabled)) {
        s.stop.edgeMm = t->number("edge_mm", s.stop.edgeMm, positive);
        if (const auto v = t->get("thickness_mm")) {
            s.stop.thicknessMm = v->asNumber(positive);
            if (*s.stop.thicknessMm < s.stop.edgeMm)
                v->fail(v->path() + " must be at least edge_mm (" + fmt(s.stop.edgeMm, 4) +
                        " mm): the knife edge is part of the plate");
        }
        s.stop.bevelDeg =
            t->number("bevel_deg", s.stop.bevelDeg, NumberRange::strictlyBetween(0, 90));
        s.stop.property = t->string("property");
        s.stop.edgeProperty = t->string("edge_property");
    }
    {
        const auto v = m.get("field_stop");
        if (v) {
            bool enabled = true;
            if (v->isBool()) {
                if (v->asBool()) v->fail(v->path() + " needs at least radius_mm: write a table");
                enabled = false;
            } else {
                const auto t = partTable(m, "field_stop", enabled);
                MechanicsSpec::FieldStop& f = s.fieldStop;
                const auto z = t->get("z_mm");
                const auto before = t->get("before_image_mm");
                if (z && before)
                    before->fail("give z_mm or before_image_mm in " + t->displayName() +
                                 ", not both");
                if (z) f.zMm = z->asNumber();
                if (before) f.beforeImageMm = before->asNumber();
                f.radiusMm = t->require("radius_mm", "aperture radius of the field stop, mm")
                                 .asNumber(positive);
                f.thicknessMm = t->number("thickness_mm", f.thicknessMm, positive);
                f.property = t->string("property");
            }
            s.fieldStop.enabled = enabled;
        }
    }
    if (const auto v = m.get("baffles")) {
        for (const TomlValue& entry : v->asArray()) {
            const TomlTable t = entry.asTable();
            MechanicsSpec::Baffle b;
            b.enabled = t.boolean("enabled", true);
            b.zMm = t.require("z_mm", "mid-plane of the baffle, global z in mm").asNumber();
            b.innerRadiusMm =
                t.require("inner_radius_mm", "aperture radius, mm").asNumber(positive);
            b.thicknessMm = t.number("thickness_mm", b.thicknessMm, positive);
            b.property = t.string("property");
            s.baffles.push_back(b);
        }
    }
    if (const auto v = m.get("parts")) {
        std::map<std::string, FileLoc> seen;
        for (const TomlValue& entry : v->asArray()) {
            const TomlTable t = entry.asTable();
            MechanicsSpec::Part part;
            part.enabled = t.boolean("enabled", true);
            const TomlValue name = t.require("name", "the part's object name");
            part.name = name.asString();
            if (part.name.empty() || part.name.find_first_of(". \t|,()*?") != std::string::npos)
                name.fail(name.path() + " '" + part.name +
                          "' must be a non-empty name without dots, spaces, wildcards or "
                          "criteria punctuation");
            if (auto [it, inserted] = seen.emplace(part.name, name.loc()); !inserted)
                name.fail("part name '" + part.name + "' is already used at " + it->second.str());
            const TomlValue profile = t.require(
                "profile_mm", "the part's outline in the (r, z) half plane, [[r, z], ...]");
            for (const TomlValue& point : profile.asArray()) {
                const std::vector<TomlValue> rz = point.asArray();
                if (rz.size() != 2) point.failExpected("a point [r, z]");
                const double r = rz[0].asNumber(NumberRange::atLeast(0.0));
                part.profileMm.push_back({r, rz[1].asNumber()});
            }
            if (part.profileMm.size() < 3)
                profile.fail(profile.path() + " needs at least 3 points, got " +
                             std::to_string(part.profileMm.size()));
            if (part.profileMm.size() > kMaxPartProfilePoints)
                profile.fail(profile.path() + " has " + std::to_string(part.profileMm.size()) +
                             " points; at most " + std::to_string(kMaxPartProfilePoints));
            // Either orientation; revolved counter-clockwise.
            if (profileArea(part.profileMm) < 0.0)
                std::reverse(part.profileMm.begin(), part.profileMm.end());
            if (const std::string defect = profileDefect(part.profileMm); !defect.empty())
                profile.fail(profile.path() + " is not a simple closed outline: " + defect);
            part.property = t.string("property");
            s.parts.push_back(std::move(part));
        }
    }
    {
        const auto v = m.get("vanes");
        if (v) {
            bool enabled = true;
            if (v->isBool()) {
                if (v->asBool())
                    v->fail(v->path() +
                            " needs count, depth_mm, from_z_mm and to_z_mm: write a "
                            "table");
                enabled = false;
            } else {
                const auto t = partTable(m, "vanes", enabled);
                MechanicsSpec::Vanes& vn = s.vanes;
                vn.count = static_cast<int>(t->require("count", "number of vanes")
                                                .asInteger(NumberRange::between(1, 10000)));
                vn.depthMm =
                    t->require("depth_mm", "radial depth from the bore, mm").asNumber(positive);
                vn.thicknessMm = t->number("thickness_mm", vn.thicknessMm, positive);
                vn.fromZMm =
                    t->require("from_z_mm", "first vane's mid-plane, global z in mm").asNumber();
                const TomlValue to = t->require("to_z_mm", "last vane's mid-plane, global z in mm");
                vn.toZMm = to.asNumber();
                if (vn.toZMm < vn.fromZMm)
                    to.fail(to.path() + " must not be less than from_z_mm (" + fmt(vn.fromZMm) +
                            ")");
                vn.property = t->string("property");
            }
            s.vanes.enabled = enabled;
        }
    }
    return s;
}

std::optional<MechanicsSpec> readMechanics(const TomlDocument& doc) {
    const auto v = doc.root().get("mechanics");
    if (!v) return std::nullopt;
    return readMechanicsTable(v->asTable());
}

}  // namespace veil
