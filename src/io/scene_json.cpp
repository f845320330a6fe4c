#include "io/scene_json.hpp"

#include "base/errors.hpp"
#include "base/image.hpp"
#include "base/progress.hpp"
#include "io/mesh_import.hpp"
#include "io/read_file.hpp"
#include "io/texture.hpp"
#include "io/vdb_read.hpp"

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>

namespace dgv {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

std::string describe(const Json& v) {
    switch (v.type()) {
        case Json::value_t::null:
            return "null";
        case Json::value_t::boolean:
            return v.get<bool>() ? "true" : "false";
        case Json::value_t::string:
            return "\"" + v.get<std::string>() + "\"";
        case Json::value_t::array:
            return "an array";
        case Json::value_t::object:
            return "an object";
        default: {
            std::string s = v.dump();
            return s.size() > 40 ? s.substr(0, 40) + "..." : s;
        }
    }
}

/// Levenshtein distance, for "did you mean" suggestions.
std::size_t editDistance(const std::string& a, const std::string& b) {
    std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        cur[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j)
            cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] != b[j - 1] ? 1 : 0)});
        std::swap(prev, cur);
    }
    return prev[b.size()];
}

/// A JSON object being read: remembers its path for messages and which keys were consumed,
/// so that finish() can reject unknown keys.
class ObjectReader {
public:
    ObjectReader(const Json& j, std::string path, const std::string& file)
        : mJson(j), mPath(std::move(path)), mFile(file) {
        if (!j.is_object()) fail("", "expected an object, got " + describe(j));
    }

    [[noreturn]] void fail(const std::string& key, const std::string& what) const {
        throw InputError(mFile, at(key), what);
    }
    std::string at(const std::string& key) const {
        if (key.empty()) return mPath.empty() ? "(top level)" : mPath;
        return mPath.empty() ? key : mPath + "." + key;
    }
    const std::string& file() const { return mFile; }

    bool has(const std::string& key) {
        mKnown.insert(key);
        return mJson.contains(key);
    }
    const Json* get(const std::string& key) {
        mKnown.insert(key);
        auto it = mJson.find(key);
        return it == mJson.end() ? nullptr : &*it;
    }

    Real number(const std::string& key, Real def, Real lo, Real hi, bool loOpen = false) {
        const Json* v = get(key);
        if (!v) return def;
        return checkNumber(key, *v, lo, hi, loOpen);
    }
    Real checkNumber(const std::string& key, const Json& v, Real lo, Real hi, bool loOpen) const {
        if (!v.is_number()) fail(key, "expected a number, got " + describe(v));
        Real x = v.get<Real>();
        if (!std::isfinite(x)) fail(key, "expected a finite number, got " + describe(v));
        if ((loOpen ? x <= lo : x < lo) || x > hi) fail(key, rangeText(lo, hi, loOpen) + ", got " + describe(v));
        return x;
    }
    static std::string rangeText(Real lo, Real hi, bool loOpen) {
        std::ostringstream os;
        if (loOpen && lo == 0 && hi == HUGE_VAL) return "expected a positive number";
        if (lo == 0 && hi == HUGE_VAL) return "expected a number >= 0";
        os << "expected a number in " << (loOpen ? "(" : "[") << lo << ", " << hi << "]";
        return os.str();
    }
    int integer(const std::string& key, int def, int lo, int hi) {
        const Json* v = get(key);
        if (!v) return def;
        // A whole number written as a float (4.0, 1e5: what a script's float gives) is that
        // integer; range-checked as a double first, so 1e300 is out of range, not a cast's UB.
        const bool whole = v->is_number_float() && std::isfinite(v->get<double>()) &&
                           v->get<double>() == std::floor(v->get<double>());
        if (!v->is_number_integer() && !whole) fail(key, "expected an integer, got " + describe(*v));
        if (whole && !(v->get<double>() >= lo && v->get<double>() <= hi))
            fail(key, "expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
                          describe(*v));
        const long long x = whole ? static_cast<long long>(v->get<double>()) : v->get<long long>();
        if (x < lo || x > hi)
            fail(key, "expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
                          describe(*v));
        return static_cast<int>(x);
    }
    bool boolean(const std::string& key, bool def) {
        const Json* v = get(key);
        if (!v) return def;
        if (!v->is_boolean()) fail(key, "expected true or false, got " + describe(*v));
        return v->get<bool>();
    }
    std::string string(const std::string& key, const std::string& def, bool nonEmpty = true) {
        const Json* v = get(key);
        if (!v) return def;
        if (!v->is_string()) fail(key, "expected a string, got " + describe(*v));
        std::string s = v->get<std::string>();
        if (nonEmpty && s.empty()) fail(key, "expected a non-empty string");
        return s;
    }
    std::string choice(const std::string& key, const std::string& def, const std::vector<std::string>& options) {
        const Json* v = get(key);
        if (!v) {
            if (def.empty()) fail(key, "missing; expected one of " + join(options));
            return def;
        }
        if (!v->is_string()) fail(key, "expected one of " + join(options) + ", got " + describe(*v));
        std::string s = v->get<std::string>();
        if (std::find(options.begin(), options.end(), s) == options.end())
            fail(key, "expected one of " + join(options) + ", got " + describe(*v));
        return s;
    }
    /// choice() onto an enum: `names` in the order the error lists them, `def` among them.
    template <typename E>
    E choiceOf(const std::string& key, E def, const std::vector<std::pair<std::string, E>>& names) {
        std::vector<std::string> options;
        std::string defName;
        for (const auto& [name, value] : names) {
            options.push_back(name);
            if (value == def) defName = name;
        }
        const std::string s = choice(key, defName, options);
        for (const auto& [name, value] : names)
            if (name == s) return value;
        return def;  // not reached: choice() refused anything else
    }
    Vec3 vec3(const std::string& key, const Vec3& def, Real lo = -HUGE_VAL, Real hi = HUGE_VAL) {
        const Json* v = get(key);
        if (!v) return def;
        if (!v->is_array() || v->size() != 3) fail(key, "expected an array of 3 numbers, got " + describe(*v));
        Vec3 r;
        for (int i = 0; i < 3; ++i) {
            const Json& e = (*v)[static_cast<std::size_t>(i)];
            std::string k = key + "[" + std::to_string(i) + "]";
            r[i] = checkNumber(k, e, lo, hi, false);
        }
        return r;
    }
    Vec3 direction(const std::string& key, const Vec3& def) {
        Vec3 d = vec3(key, def);
        if (d.norm() < 1e-12) fail(key, "expected a non-zero direction");
        return d.normalized();
    }
    Vec3 color(const std::string& key, const Vec3& defLinear) {
        if (!has(key)) return defLinear;
        Vec3 c = vec3(key, Vec3::Zero(), 0.0, 1.0);
        return Vec3(decodeSrgb(c.x()), decodeSrgb(c.y()), decodeSrgb(c.z()));
    }

    /// Calls f(reader) for the sub-object at `key` if present.
    template <typename F>
    void object(const std::string& key, F&& f) {
        const Json* v = get(key);
        if (!v) return;
        ObjectReader sub(*v, at(key), mFile);
        f(sub);
        sub.finish();
    }
    /// Calls f(reader, index) for each object of the array at `key`.
    template <typename F>
    void array(const std::string& key, F&& f) {
        const Json* v = get(key);
        if (!v) return;
        if (!v->is_array()) fail(key, "expected an array, got " + describe(*v));
        for (std::size_t i = 0; i < v->size(); ++i) {
            ObjectReader sub((*v)[i], at(key) + "[" + std::to_string(i) + "]", mFile);
            f(sub, static_cast<int>(i));
            sub.finish();
        }
    }

    /// Rejects keys nobody asked for, suggesting the closest known one.
    void finish() const {
        for (auto it = mJson.begin(); it != mJson.end(); ++it) {
            if (mKnown.count(it.key())) continue;
            std::string best;
            std::size_t bestDist = 3;
            for (const auto& k : mKnown) {
                std::size_t d = editDistance(it.key(), k);
                if (d < bestDist) bestDist = d, best = k;
            }
            std::string what = "unknown key";
            if (!best.empty())
                what += " (did you mean '" + best + "'?)";
            else
                what += "; known keys here: " + join(std::vector<std::string>(mKnown.begin(), mKnown.end()));
            throw InputError(mFile, at(it.key()), what);
        }
    }

    static std::string join(const std::vector<std::string>& v) {
        std::string s;
        for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + ("'" + v[i] + "'");
        return s;
    }

private:
    const Json& mJson;
    std::string mPath;
    const std::string& mFile;
    std::set<std::string> mKnown;
};

/// `focal_length` and `sensor` (millimetres) of a camera or a key, instead of `fov`; `inherited`
/// when neither is given (a key takes its camera's lens).
std::optional<Lens> readLens(ObjectReader& c, std::optional<Lens> inherited) {
    if (!c.has("focal_length")) {
        if (c.has("sensor")) c.fail("sensor", "applies with focal_length");
        return inherited;
    }
    if (c.has("fov")) c.fail("focal_length", "give fov or focal_length, not both");
    Lens lens;
    lens.focalLengthMm = c.number("focal_length", lens.focalLengthMm, 1, 10000);
    lens.sensorMm = c.number("sensor", inherited ? inherited->sensorMm : lens.sensorMm, 1, 500);
    return lens;
}

/// The eye far beyond what it looks at overflows the view direction (a NaN that reads as "up is
/// parallel to the view"): refused with its own message. 1e12 m is past any shot's scale.
void checkCameraSpan(ObjectReader& c, const Vec3& eye, const Vec3& target) {
    const Real span = (eye - target).lpNorm<Eigen::Infinity>();
    if (!(span <= 1e12)) {
        char line[160];
        std::snprintf(line, sizeof line, "lies %.3g m from the target; keep the camera within 1e+12 m of it", span);
        c.fail("eye", line);
    }
}

std::string lineColumn(const std::string& text, std::size_t byte) {
    std::size_t line = 1, col = 1;
    for (std::size_t i = 0; i < byte && i < text.size(); ++i) {
        if (text[i] == '\n')
            ++line, col = 1;
        else
            ++col;
    }
    return "line " + std::to_string(line) + ", column " + std::to_string(col);
}

fs::path resolveInput(const fs::path& sceneDir, const std::string& p) {
    fs::path path(p);
    return (path.is_absolute() ? path : sceneDir / path).lexically_normal();
}

TransformDesc readTransform(ObjectReader& r) {
    TransformDesc t;
    t.translate = r.vec3("translate", t.translate);
    t.rotateDegrees = r.vec3("rotate", t.rotateDegrees);
    if (const Json* u = r.get("units")) {
        // Metres per unit: a name or a number.
        static const std::vector<std::pair<std::string, Real>> kUnits = {{"m", 1},     {"cm", 0.01},   {"mm", 0.001},
                                                                         {"km", 1000}, {"in", 0.0254}, {"ft", 0.3048}};
        if (u->is_number()) {
            t.units = r.checkNumber("units", *u, 0, HUGE_VAL, true);
        } else {
            const std::string name = u->is_string() ? u->get<std::string>() : "";
            for (const auto& [n, k] : kUnits)
                if (n == name) t.units = k;
            if (!(t.units > 0))
                r.fail("units", "expected m, cm, mm, km, in, ft or metres per unit (a number > 0), got " + u->dump());
        }
    }
    if (const Json* s = r.get("scale")) {
        if (s->is_number()) {
            Real k = r.checkNumber("scale", *s, 0, HUGE_VAL, true);
            t.scale = Vec3::Constant(k);
        } else {
            t.scale = r.vec3("scale", t.scale);
            for (int i = 0; i < 3; ++i)
                if (!(std::abs(t.scale[i]) > 0))
                    r.fail("scale[" + std::to_string(i) + "]", "expected a non-zero scale");
        }
    }
    return t;
}

Keyframes readKeyframes(ObjectReader& r, const std::string& key, Real def) {
    Keyframes k;
    const Json* v = r.get(key);
    if (!v) {
        k.keys.push_back({1, def});
        return k;
    }
    if (v->is_number()) {
        k.keys.push_back({1, r.checkNumber(key, *v, -HUGE_VAL, HUGE_VAL, false)});
        return k;
    }
    if (!v->is_array() || v->empty())
        r.fail(key, "expected a number or an array of [frame, value] keys, got " + describe(*v));
    for (std::size_t i = 0; i < v->size(); ++i) {
        const Json& e = (*v)[i];
        std::string ki = key + "[" + std::to_string(i) + "]";
        if (!e.is_array() || e.size() != 2) r.fail(ki, "expected a [frame, value] pair, got " + describe(e));
        Real f = r.checkNumber(ki + "[0]", e[0], -HUGE_VAL, HUGE_VAL, false);
        Real val = r.checkNumber(ki + "[1]", e[1], -HUGE_VAL, HUGE_VAL, false);
        if (!k.keys.empty() && f <= k.keys.back().first) r.fail(ki, "key frames must increase");
        k.keys.push_back({f, val});
    }
    return k;
}

void readVoxel(ObjectReader& r, VoxeliseSettings& v) {
    bool hasSize = r.has("voxel_size"), hasRes = r.has("resolution");
    if (hasSize && hasRes) r.fail("voxel_size", "give voxel_size or resolution, not both");
    if (!hasSize && !hasRes) v.resolution = 48;
    if (hasSize) v.voxelSize = r.number("voxel_size", 0, 0, HUGE_VAL, true);
    if (hasRes) v.resolution = r.integer("resolution", 48, 2, 2048);
    for (const std::string& problem : v.validate()) {
        auto colon = problem.find(':');
        r.fail(problem.substr(0, colon), colon == std::string::npos ? problem : problem.substr(colon + 2));
    }
}

/// A scene or object name names files such as .<name>.0001.png.tmp-<host>-<pid>: at most 200
/// characters keeps every one under the 255 a file name may have (a longer one failed only after
/// the setup, on the first frame's write).
void limitNameLength(const ObjectReader& r, const std::string& name, const char* names) {
    constexpr std::size_t kMaxNameLength = 200;
    if (name.size() > kMaxNameLength)
        r.fail("name", "use at most " + std::to_string(kMaxNameLength) + " characters (it names " + names + "), got " +
                           std::to_string(name.size()));
}

/// render.lights: the rig, replacing the studio rig (docs/rendering.md, "Lights"). The first
/// directional light casts the shadows unless it says otherwise; one light at most does.
void readLights(ObjectReader& g, std::vector<Light>& lights) {
    int shadowing = -1;
    g.array("lights", [&](ObjectReader& l, int i) {
        if (i >= kMaxLights) l.fail("", "a rig holds at most " + std::to_string(kMaxLights) + " lights");
        Light d;
        d.type = l.choiceOf("type", Light::Type::Directional,
                            {{"directional", Light::Type::Directional}, {"point", Light::Type::Point}});
        const bool directional = d.type == Light::Type::Directional;
        if (directional && l.has("position")) l.fail("position", "a directional light has a 'direction', not a position");
        if (!directional && l.has("direction")) l.fail("direction", "a point light has a 'position', not a direction");
        const char* where = directional ? "direction" : "position";
        if (!l.has(where)) l.fail(where, directional ? "missing: the direction towards the light" : "missing");
        d.vector = l.vec3(where, d.vector);
        if (directional && !(d.vector.norm() > 0)) l.fail("direction", "must not be [0, 0, 0]");
        d.colour = l.color("color", Vec3::Ones()) * l.number("intensity", 1, 0, 1e9);
        d.cameraRelative = l.choice("attach", "world", {"world", "camera"}) == "camera";
        d.shadows = l.boolean("shadows", directional && shadowing < 0);
        if (d.shadows && !directional) l.fail("shadows", "only a directional light casts shadows");
        if (d.shadows && shadowing >= 0)
            l.fail("shadows", "one light casts shadows, and lights[" + std::to_string(shadowing) + "] already does");
        if (d.shadows && !(d.vector.y() > 0))
            l.fail("shadows", "a light that casts shadows must shine from above (direction y > 0)");
        if (d.shadows) shadowing = i;
        d.shininess = l.number("specular", 32, 0, 1e4);
        d.floor = l.boolean("floor", d.floor);
        lights.push_back(d);
    });
    if (g.has("lights") && lights.empty()) g.fail("lights", "expected at least one light (leave it out for the studio rig)");
}

/// The JSON document of a scene file, or one line naming what is malformed.
Json parseJson(const std::string& text, const std::string& file) {
    Json root;
    try {
        root = Json::parse(text);
    } catch (const Json::parse_error& e) {
        std::string msg = e.what();
        // nlohmann: "[json.exception.parse_error.101] parse error at line 3, column 5: ..."
        auto p = msg.find("parse error");
        if (p != std::string::npos) msg = msg.substr(p);
        if (text.find_first_not_of(" \t\r\n") == std::string::npos) msg = "the file is empty";
        throw InputError(file, "",
                         "malformed JSON: " + libraryMessage(msg) + " (" + lineColumn(text, e.byte > 0 ? e.byte - 1 : 0) + ")");
    } catch (const Json::exception& e) {
        // e.g. out_of_range.406, a number too large for a double ("1E1111111"; found by fuzz_scene)
        std::string msg = e.what();
        const auto p = msg.find("] ");
        if (p != std::string::npos) msg = msg.substr(p + 2);
        throw InputError(file, "", "malformed JSON: " + libraryMessage(msg));
    }

    return root;
}

/// objects[i].primitive.
void readPrimitive(ObjectReader& p, PrimitiveDesc& pd) {
    std::string type = p.choice("type", "", {"sphere", "box", "torus", "capsule"});
    if (type == "sphere") {
        pd.type = PrimitiveType::Sphere;
        pd.radius = p.number("radius", 0.5, 0, HUGE_VAL, true);
    } else if (type == "box") {
        pd.type = PrimitiveType::Box;
        pd.size = p.vec3("size", Vec3::Ones());
        for (int k = 0; k < 3; ++k)
            if (!(pd.size[k] > 0)) p.fail("size[" + std::to_string(k) + "]", "expected a positive edge length");
    } else if (type == "torus") {
        pd.type = PrimitiveType::Torus;
        pd.majorRadius = p.number("major_radius", 0.5, 0, HUGE_VAL, true);
        pd.minorRadius = p.number("minor_radius", 0.2, 0, HUGE_VAL, true);
        if (pd.minorRadius >= pd.majorRadius)
            p.fail("minor_radius", "must be smaller than major_radius (a torus with no hole)");
    } else {
        pd.type = PrimitiveType::Capsule;
        pd.radius = p.number("radius", 0.3, 0, HUGE_VAL, true);
        pd.height = p.number("height", 1.0, 0, HUGE_VAL, false);
    }
}

/// objects[i].material: the preset first (jelly is MaterialDesc's default), then the keys
/// given override it.
void readMaterial(ObjectReader& m, MaterialDesc& mat) {
    const std::string preset = m.choice("preset", "jelly", {"jelly", "putty", "goo"});
    if (preset == "goo") {
        mat.stiffnessFrom = MaterialDesc::StiffnessFrom::Value;
        mat.stiffness = 0;
        mat.wobbles = 0;
        mat.damping = 0;
        mat.viscosity = 1;
    } else if (preset == "putty") {
        mat.yield = 0.1;
        mat.wobbles = 1;
    }
    const int ways = int(m.has("stiffness")) + int(m.has("wobble_hz")) + int(m.has("sag"));
    if (ways > 1) m.fail(m.has("sag") ? "sag" : "wobble_hz", "give one of 'stiffness', 'wobble_hz' and 'sag'");
    if (m.has("damping") && m.has("wobbles")) m.fail("wobbles", "give 'damping' or 'wobbles', not both");
    mat.density = m.number("density", mat.density, 0, HUGE_VAL, true);
    mat.solver = m.choiceOf("solver", mat.solver,
                            {{"chain", MaterialDesc::Solver::Chain}, {"one", MaterialDesc::Solver::One}});
    if (m.has("stiffness")) {
        mat.stiffnessFrom = MaterialDesc::StiffnessFrom::Value;
        mat.stiffness = m.number("stiffness", 0, 0, 1e8);
    } else if (m.has("wobble_hz")) {
        mat.stiffnessFrom = MaterialDesc::StiffnessFrom::WobbleHz;
        mat.wobbleHz = m.number("wobble_hz", 0, 0, 1000, true);
    } else if (m.has("sag")) {
        mat.stiffnessFrom = MaterialDesc::StiffnessFrom::Sag;
        mat.sag = m.number("sag", 0, 0.001, 10);
    }
    if (m.has("damping")) {
        mat.damping = m.number("damping", mat.damping, 0, 1e6);
        mat.wobbles = 0;
    } else if (m.has("wobbles")) {
        mat.wobbles = m.number("wobbles", 0, 0, 1000, true);
    }
    const bool goo = mat.stiffnessFrom == MaterialDesc::StiffnessFrom::Value && mat.stiffness == 0;
    if (goo) mat.wobbles = 0;  // nothing wobbles: `damping` (default 1) as given
    if (goo && m.has("wobbles")) m.fail("wobbles", "needs a stiffness (goo does not wobble): give 'damping'");
    mat.viscosity = m.number("viscosity", mat.viscosity, 0, 1e6);
    mat.yield = m.number("yield", mat.yield, 0, 10);
    if (mat.yield > 0 && goo)
        m.fail("yield", "needs a 'stiffness' > 0 (goo has no rest shape to yield; it flows at any strain)");
    mat.volumeTolerance = m.number("volume_tolerance", mat.volumeTolerance, 1e-12, 0.1);
    mat.maxDeltaGamma = m.number("max_delta_gamma", mat.maxDeltaGamma, 0, 1, true);
    mat.pinnedLoad = m.boolean("pinned_load", mat.pinnedLoad);
    mat.reparametrise = m.boolean("reparametrise", mat.reparametrise);
}

/// objects[i].pin: a box, a ball or a vertex group.
void readPin(ObjectReader& p, ObjectDesc& d) {
    const bool box = p.has("min") || p.has("max"), ball = p.has("centre") || p.has("radius"),
               group = p.has("group");
    if (int(box) + int(ball) + int(group) != 1)
        p.fail("", "give a box ('min' and 'max'), a ball ('centre' and 'radius') or a vertex group ('group')");
    if (group) {
        if (d.isPrimitive) p.fail("group", "a vertex group needs a mesh object (a primitive has none)");
        d.pin.kind = PinDesc::Kind::Group;
        d.pin.group = p.string("group", "");
        if (d.pin.group.empty())
            p.fail("group", "expected the name of a mesh or node in the object's mesh file");
    } else if (box) {
        d.pin.kind = PinDesc::Kind::Box;
        d.pin.min = p.vec3("min", Vec3::Zero());
        d.pin.max = p.vec3("max", Vec3::Zero());
        for (int k = 0; k < 3; ++k)
            if (!(d.pin.max[k] >= d.pin.min[k])) p.fail("max", "must be >= min in every coordinate");
    } else {
        d.pin.kind = PinDesc::Kind::Ball;
        d.pin.centre = p.vec3("centre", Vec3::Zero());
        d.pin.radius = p.number("radius", 0, 0, HUGE_VAL, true);
    }
}

/// objects[i].
ObjectDesc readObject(ObjectReader& o, int i, const fs::path& sceneDir) {
    ObjectDesc d;
    d.name = o.string("name", "object" + std::to_string(i));
    limitNameLength(o, d.name, "mesh cache files");
    bool hasMesh = o.has("mesh"), hasPrim = o.has("primitive");
    if (hasMesh == hasPrim) o.fail("", "give exactly one of 'mesh' (a file) or 'primitive'");
    if (hasMesh) {
        d.meshPath = resolveInput(sceneDir, o.string("mesh", "")).string();
        d.meshName = o.string("mesh_name", "");
    }
    o.object("primitive", [&](ObjectReader& p) {
        d.isPrimitive = true;
        readPrimitive(p, d.primitive);
    });
    o.object("transform", [&](ObjectReader& t) {
        d.transform = readTransform(t);
        if (d.isPrimitive && t.has("units"))
            t.fail("units", "applies to a mesh file (a primitive is in metres; use scale)");
    });
    readVoxel(o, d.voxel);
    d.colorGiven = o.has("color");
    d.color = o.color("color", d.color);
    d.deformable = o.boolean("deformable", true);
    o.object("material", [&](ObjectReader& m) { readMaterial(m, d.material); });
    d.velocity = o.vec3("velocity", d.velocity);
    d.spinDegrees = o.vec3("spin", d.spinDegrees);
    o.object("pin", [&](ObjectReader& p) { readPin(p, d); });
    return d;
}

/// curves[i] (the seed's curve figures).
CurveDesc readCurve(ObjectReader& c, int i, const fs::path& sceneDir) {
    CurveDesc d;
    d.name = c.string("name", "curve" + std::to_string(i));
    const bool hasFile = c.has("file"), hasRing = c.has("ring");
    if (hasFile == hasRing) c.fail("", "give exactly one of 'file' (a curve file) or 'ring'");
    if (hasFile) d.curvePath = resolveInput(sceneDir, c.string("file", "")).string();
    c.object("ring", [&](ObjectReader& g) {
        d.centre = g.vec3("centre", d.centre);
        d.normal = g.direction("normal", d.normal);
        d.radius = g.number("radius", d.radius, 0, HUGE_VAL, true);
        d.segments = g.integer("segments", d.segments, 3, 10000000);
    });
    if (const Json* m = c.get("motion")) {
        if (!m->is_array() || m->empty())
            c.fail("motion", "expected an array of [frame, [x, y, z]] keys, got " + describe(*m));
        for (std::size_t k = 0; k < m->size(); ++k) {
            const Json& e = (*m)[k];
            const std::string key = "motion[" + std::to_string(k) + "]";
            if (!e.is_array() || e.size() != 2 || !e[1].is_array() || e[1].size() != 3)
                c.fail(key, "expected a [frame, [x, y, z]] key, got " + describe(e));
            const Real f = c.checkNumber(key + "[0]", e[0], -HUGE_VAL, HUGE_VAL, false);
            Vec3 v;
            for (int a = 0; a < 3; ++a)
                v[a] = c.checkNumber(key + "[1][" + std::to_string(a) + "]", e[1][static_cast<std::size_t>(a)],
                                     -HUGE_VAL, HUGE_VAL, false);
            if (!d.motion.empty() && f <= d.motion.back().first) c.fail(key, "key frames must increase");
            d.motion.push_back({f, v});
        }
    }
    d.color = c.color("color", d.color);
    d.tubeRadius = c.number("tube_radius", d.tubeRadius, 0, HUGE_VAL, true);
    return d;
}

/// forces[i].
ForceTerm readForce(ObjectReader& f) {
    ForceTerm d;
    std::string type = f.choice("type", "", {"gravity", "attractor", "vortex", "burst", "wind", "torsion"});
    if (type == "gravity") {
        d.kind = ForceKind::Gravity;
        d.direction = f.direction("direction", d.direction);
        d.strength = readKeyframes(f, "strength", 9.81);
    } else if (type == "attractor") {
        d.kind = ForceKind::Attractor;
        d.centre = f.vec3("position", d.centre);
        d.radius = f.number("radius", 1, 0, HUGE_VAL, true);
        d.softening = f.number("softening", 0.25 * d.radius, 0, HUGE_VAL, true);
        d.falloff = f.number("falloff", 2, 0, 4);
        d.strength = readKeyframes(f, "strength", 1);
    } else if (type == "vortex") {
        d.kind = ForceKind::Vortex;
        d.centre = f.vec3("position", d.centre);
        d.axis = f.direction("axis", d.axis);
        d.radius = f.number("radius", 1, 0, HUGE_VAL, true);
        d.falloff = f.number("falloff", 1, 0, 4);
        d.strength = readKeyframes(f, "strength", 1);
    } else if (type == "torsion") {
        d.kind = ForceKind::Torsion;
        d.centre = f.vec3("position", d.centre);
        d.axis = f.direction("axis", d.axis);
        d.radius = f.number("radius", 1, 0, HUGE_VAL, true);
        d.strength = readKeyframes(f, "strength", 1);
    } else if (type == "burst") {
        d.kind = ForceKind::Burst;
        d.centre = f.vec3("position", d.centre);
        d.radius = f.number("radius", 1, 0, HUGE_VAL, true);
        d.strength = readKeyframes(f, "strength", 1);
    } else {
        d.kind = ForceKind::Wind;
        d.direction = f.direction("direction", Vec3::UnitX());
        d.strength = readKeyframes(f, "strength", 1);
        d.turbulence = f.number("turbulence", 0, 0, HUGE_VAL);
        d.scale = f.number("scale", 1, 0, HUGE_VAL, true);
        d.seed = static_cast<unsigned>(f.integer("seed", 1, 0, 1 << 30));
        d.modes = f.integer("modes", 32, 1, 4096);
    }
    return d;
}

/// A levelset collider: its grid is loaded here, so a bad file stops every command before
/// anything is written.
void readLevelSetCollider(ObjectReader& c, ColliderDesc& d, const fs::path& sceneDir) {
    d.type = ColliderType::LevelSet;
    if (!c.has("file")) c.fail("file", "missing; a levelset collider needs a .vdb file");
    d.levelSetPath = resolveInput(sceneDir, c.string("file", "")).string();
    d.levelSetGrid = c.string("grid", "");
    c.object("transform", [&](ObjectReader& t) {
        d.transform = readTransform(t);
        if (t.has("units")) t.fail("units", "applies to a mesh file (a level set is in the file's metres)");
        const Vec3& k = d.transform.scale;
        if (k.x() != k.y() || k.x() != k.z() || !(k.x() > 0))
            t.fail("scale", "a levelset collider takes a positive uniform scale only (a number)");
    });
    try {
        d.levelSet = std::make_shared<const SdfGrid>(readVdbLevelSet(d.levelSetPath, d.levelSetGrid));
    } catch (const InputError& e) {
        c.fail("file", e.what());
    }
}

/// A mesh collider: imported and turned into a signed-distance grid here, so a bad mesh stops
/// every command before anything is written.
void readMeshCollider(ObjectReader& c, ColliderDesc& d, const fs::path& sceneDir) {
    d.type = ColliderType::Mesh;
    if (!c.has("mesh")) c.fail("mesh", "missing; a mesh collider needs a mesh file");
    d.meshPath = resolveInput(sceneDir, c.string("mesh", "")).string();
    c.object("transform", [&](ObjectReader& t) { d.transform = readTransform(t); });
    d.meshVoxelSize = c.number("voxel_size", 0, 0, HUGE_VAL);
    const Mat3 A = d.transform.linear();
    if (!(std::abs(A.determinant()) > 0)) c.fail("transform", "the transform flattens the mesh (a zero scale)");
    try {
        MeshImportOptions opts;
        opts.unitScale = d.transform.units;
        TriangleMesh mesh = importMesh(d.meshPath, opts);
        transformMesh(mesh, A, d.transform.translate);
        if (const std::string w = unlikelySizeWarning(mesh, "mesh collider " + d.meshPath); !w.empty())
            logWarning(w);
        const MeshReport report = analyseMesh(mesh);
        if (!report.closed || !report.manifold)
            throw InputError(d.meshPath, "",
                             "a mesh collider must be closed and consistently oriented (" +
                                 std::to_string(report.boundaryEdges) + " open edges, " +
                                 std::to_string(report.nonManifoldEdges) +
                                 " non-manifold edges): its inside is what bodies are kept out of");
        // importMesh turned inside-out parts around; what is left without volume is flat
        if (!(report.signedVolume > 0))
            throw InputError(d.meshPath, "", "the mesh encloses no volume (it is flat)");
        const Vec3 extent = report.bounds.size();
        const Real voxel = d.meshVoxelSize > 0 ? d.meshVoxelSize : extent.maxCoeff() / 128;
        d.levelSet = std::make_shared<const SdfGrid>(meshLevelSet(mesh, voxel, 3, d.meshPath));
        d.worldMesh = std::make_shared<const TriangleMesh>(std::move(mesh));
    } catch (const InputError& e) {
        c.fail("mesh", e.what());
    }
}

/// colliders[i].
ColliderDesc readCollider(ObjectReader& c, const fs::path& sceneDir) {
    ColliderDesc d;
    std::string type = c.choice("type", "", {"ground", "sphere", "mesh", "levelset", "plane"});
    if (type == "ground") {
        d.type = ColliderType::Ground;
        d.height = c.number("height", 0, -HUGE_VAL, HUGE_VAL);
    } else if (type == "plane") {
        d.type = ColliderType::Plane;
        d.centre = c.vec3("point", d.centre);
        if (!c.has("normal")) c.fail("normal", "missing; a plane needs the normal of its free side");
        d.normal = c.direction("normal", d.normal);
        d.size = c.number("size", d.size, 0, 1e6, true);
    } else if (type == "sphere") {
        d.type = ColliderType::Sphere;
        d.centre = c.vec3("centre", d.centre);
        d.radius = c.number("radius", 1, 0, HUGE_VAL, true);
    } else if (type == "levelset") {
        readLevelSetCollider(c, d, sceneDir);
    } else {
        readMeshCollider(c, d, sceneDir);
    }
    d.friction = c.number("friction", d.friction, 0, 1);
    d.restitution = c.number("restitution", d.restitution, 0, 1);
    return d;
}

/// camera.
void readCamera(ObjectReader& c, CameraDesc& d) {
    std::string type = c.choice("type", "turntable", {"turntable", "look_at", "keyframed"});
    d.fovDegrees = c.number("fov", d.fovDegrees, 1, 170);
    d.lens = readLens(c, std::nullopt);
    c.object("depth_of_field", [&](ObjectReader& f) {
        d.depthOfField = f.boolean("enabled", true);
        d.fStop = f.number("f_stop", d.fStop, 0, 1e4, true);
        d.focusDistance = f.number("focus_distance", d.focusDistance, 0, 1e7, true);
        d.dofSamples = f.integer("samples", d.dofSamples, 2, 256);
    });
    if (type == "turntable") {
        d.type = CameraType::Turntable;
        d.degrees = c.number("degrees", d.degrees, -36000, 36000);
        d.startDegrees = c.number("start", d.startDegrees, -36000, 36000);
        d.elevationDegrees = c.number("elevation", d.elevationDegrees, -89, 89);
        d.margin = c.number("margin", d.margin, 0.1, 100);
    } else if (type == "keyframed") {
        d.type = CameraType::Keyframed;
        d.up = c.direction("up", d.up);
        if (!c.has("keys")) c.fail("keys", "missing; a keyframed camera needs at least one key");
        c.array("keys", [&](ObjectReader& k, int i) {
            CameraKey key;
            key.frame = k.number("frame", 0, -HUGE_VAL, HUGE_VAL);
            if (!k.has("frame")) k.fail("frame", "missing");
            key.eye = k.vec3("eye", key.eye);
            key.target = k.vec3("target", key.target);
            key.fovDegrees = k.number("fov", d.fovDegrees, 1, 170);
            key.lens = readLens(k, k.has("fov") ? std::nullopt : d.lens);  // a key's fov overrides the camera's lens
            if (i > 0 && key.frame <= d.keys.back().frame) k.fail("frame", "key frames must increase");
            checkCameraSpan(k, key.eye, key.target);
            if ((key.eye - key.target).norm() < 1e-9) k.fail("target", "must differ from eye");
            if ((key.eye - key.target).normalized().cross(d.up).norm() < 1e-6)
                k.fail("eye", "the view direction must not be parallel to up");
            d.keys.push_back(key);
        });
        if (d.keys.empty()) c.fail("keys", "needs at least one key");
    } else {
        d.type = CameraType::LookAt;
        d.eye = c.vec3("eye", d.eye);
        d.target = c.vec3("target", d.target);
        d.up = c.direction("up", d.up);
        checkCameraSpan(c, d.eye, d.target);
        if ((d.eye - d.target).norm() < 1e-9) c.fail("target", "must differ from eye");
        if ((d.eye - d.target).normalized().cross(d.up).norm() < 1e-6)
            c.fail("up", "must not be parallel to the view direction");
    }
}

/// render.contact: how contacts are highlighted.
void readContactHighlight(ObjectReader& c, RenderDesc& d) {
    d.contactMode = c.choiceOf("mode", ContactHighlightMode::Depth,
                               {{"off", ContactHighlightMode::Off},
                                {"depth", ContactHighlightMode::Depth},
                                {"recent", ContactHighlightMode::Recent}});
    d.contactDepthMax = c.number("depth_max", 0, 0, HUGE_VAL);
    d.contactFadeFrames = c.integer("fade_frames", d.contactFadeFrames, 1, 100000);
    d.contactLowSet = c.has("low");
    d.contactLow = c.color("low", d.contactLow);
    d.contactHighSet = c.has("high");
    d.contactHigh = c.color("high", d.contactHigh);
    d.contactSpread = c.integer("spread", d.contactSpread, 0, 16);
    d.contactFootprint = c.boolean("footprint", d.contactFootprint);
    d.contactGlow = c.number("glow", d.contactGlow, 0, 1);
}

/// render.pins: true, false or {"show", "color", "point_size"}.
void readPinDisplay(ObjectReader& g, RenderDesc& d) {
    if (g.has("pins")) {
        const Json* v = g.get("pins");
        if (v->is_boolean()) {
            d.pins = v->get<bool>();
        } else if (!v->is_object()) {
            g.fail("pins",
                   "expected true, false or an object {\"show\", \"color\", \"point_size\"}, got " + describe(*v));
        } else {
            g.object("pins", [&](ObjectReader& p) {
                d.pins = p.boolean("show", true);
                d.pinColour = p.color("color", d.pinColour);
                d.pinPointSize = p.number("point_size", d.pinPointSize, 1, 64);
            });
        }
    }
}

/// render.overlays: the lattice's points and the GLN loops drawn over the frame.
void readOverlays(ObjectReader& o, RenderDesc& d) {
    d.overlayLattice = o.boolean("lattice", d.overlayLattice);
    d.overlayLatticeSet = o.choiceOf("lattice_set", d.overlayLatticeSet,
                                     {{"boundary", LatticeDotSet::Boundary}, {"all", LatticeDotSet::All}});
    d.overlayLatticeColour = o.color("lattice_color", d.overlayLatticeColour);
    d.overlayPointSize = o.number("point_size", d.overlayPointSize, 1, 64);
    d.overlayGlnLoops = o.boolean("gln_loops", d.overlayGlnLoops);
    d.overlayGlnLoopSet = o.choiceOf(
        "gln_loop_set", d.overlayGlnLoopSet,
        {{"contact", GlnLoopSet::Contact}, {"all", GlnLoopSet::All}, {"coarse", GlnLoopSet::Coarse}});
    d.overlayGlnColour = o.color("gln_color", d.overlayGlnColour);
    d.overlayLineWidth = o.number("line_width", d.overlayLineWidth, 1, 64);
}

/// render.motion_blur: true, false or {"shutter", "samples"}.
void readMotionBlur(ObjectReader& g, RenderDesc& d) {
    if (!g.has("motion_blur")) return;
    const Json* v = g.get("motion_blur");
    if (v->is_boolean()) {
        d.motionBlur = v->get<bool>();
    } else if (!v->is_object()) {
        g.fail("motion_blur", "expected true, false or an object {\"shutter\", \"samples\"}, got " + describe(*v));
    } else {
        g.object("motion_blur", [&](ObjectReader& m) {
            d.motionBlur = true;
            d.motionBlurShutter = m.number("shutter", d.motionBlurShutter, 0, 360, true);
            d.motionBlurSamples = m.integer("samples", d.motionBlurSamples, 2, 64);
        });
    }
}

/// render.environment: {"color"}, {"sky", "ground"} or {"image", "rotation"}, with "intensity".
void readEnvironment(ObjectReader& e, RenderDesc& d, const fs::path& sceneDir) {
    const int given = (e.has("color") ? 1 : 0) + (e.has("sky") ? 1 : 0) + (e.has("image") ? 1 : 0);
    if (given != 1) e.fail("", "give one of \"color\", \"sky\" (with \"ground\") or \"image\"");
    if (e.has("ground") && !e.has("sky")) e.fail("ground", "goes with \"sky\"");
    if (e.has("rotation") && !e.has("image")) e.fail("rotation", "turns an \"image\"");
    d.environmentIntensity = e.number("intensity", 1, 0, 1e6);
    if (e.has("color")) {
        d.environment = RenderDesc::Environment::Colour;
        d.environmentColour = e.color("color", d.environmentColour);
    } else if (e.has("sky")) {
        d.environment = RenderDesc::Environment::Sky;
        d.environmentColour = e.color("sky", d.environmentColour);
        d.environmentGround = e.color("ground", d.environmentGround);
    } else {
        d.environment = RenderDesc::Environment::Image;
        d.environmentImage = resolveInput(sceneDir, e.string("image", "")).string();
        d.environmentRotation = e.number("rotation", 0, -36000, 36000);
        try {
            LinearRgbImage img = readLinearImage(d.environmentImage);
            d.environmentWidth = img.width;
            d.environmentHeight = img.height;
            d.environmentPixels = std::make_shared<const std::vector<Vec3>>(std::move(img.pixels));
        } catch (const InputError& err) {
            e.fail("image", err.what());
        }
    }
}

/// render.
void readRender(ObjectReader& g, RenderDesc& d, const fs::path& sceneDir) {
    d.width = g.integer("width", d.width, 16, 16384);
    d.height = g.integer("height", d.height, 16, 16384);
    d.supersample = g.integer("supersample", d.supersample, 1, 4);
    d.background = g.color("background", d.background);
    d.transparent = g.boolean("transparent", d.transparent);
    d.ground = g.boolean("ground", d.ground);
    d.groundGiven = g.has("ground");
    d.bitDepth = g.integer("bit_depth", d.bitDepth, 8, 16);
    d.format = g.choiceOf("format", d.format, {{"png", RenderDesc::Format::Png}, {"exr", RenderDesc::Format::Exr}});
    if (d.format == RenderDesc::Format::Exr && g.has("bit_depth"))
        g.fail("bit_depth", "applies to PNG frames (EXR frames are half float)");
    d.creaseDegrees = g.number("crease_degrees", d.creaseDegrees, 0, 180);
    readLights(g, d.lights);
    d.shadowSoftness = g.number("shadow_softness", d.shadowSoftness, 0, 15);
    d.colliderOpacity = g.number("collider_opacity", d.colliderOpacity, 0, 1);
    readMotionBlur(g, d);
    g.object("environment", [&](ObjectReader& e) { readEnvironment(e, d, sceneDir); });
    if (d.bitDepth != 8 && d.bitDepth != 16) g.fail("bit_depth", "expected 8 or 16");
    g.object("contact", [&](ObjectReader& c) { readContactHighlight(c, d); });
    readPinDisplay(g, d);
    g.object("overlays", [&](ObjectReader& o) { readOverlays(o, d); });
    if (static_cast<long long>(d.width) * d.supersample > 16384 ||
        static_cast<long long>(d.height) * d.supersample > 16384)
        g.fail("supersample", "width and height times supersample must stay within 16384 (the GL limit)");
}

}  // namespace

SceneDesc parseScene(const std::string& text, const fs::path& path) {
    const std::string file = path.string();
    const Json root = parseJson(text, file);
    const fs::path sceneDir = fs::absolute(path).parent_path();
    SceneDesc s;
    s.path = file;
    ObjectReader r(root, "", file);

    s.name = r.string("name", path.stem().string());
    for (char c : s.name)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-'))
            r.fail("name", "use letters, digits, '_' and '-' only (it names output files), got \"" + s.name + "\"");
    limitNameLength(r, s.name, "output files");

    r.object("frames", [&](ObjectReader& f) {
        s.frameStart = f.integer("start", 1, 0, 999999);
        s.frameEnd = f.integer("end", s.frameStart, 0, 999999);
        if (s.frameEnd < s.frameStart) f.fail("end", "must be >= start (" + std::to_string(s.frameStart) + ")");
        s.fps = f.number("fps", 24, 0, 1000, true);
    });
    s.substeps = r.integer("substeps", 1, 1, 1000);
    s.maxSubsteps = r.integer("max_substeps", std::max(16, s.substeps), s.substeps, 1000);
    s.maxSubstepsGiven = r.has("max_substeps");
    s.cfl = r.number("cfl", 1, 0, 100, true);
    r.object("collision", [&](ObjectReader& c) {
        s.collision.detect = c.choiceOf("detect", CollisionDesc::Detect::Sdf,
                                        {{"sdf", CollisionDesc::Detect::Sdf}, {"gln", CollisionDesc::Detect::Gln}});
        s.collision.coarseToFine = c.boolean("coarse_to_fine", false);
        s.collision.objects = c.boolean("objects", s.collision.objects);
        s.collision.distance =
            c.choiceOf("distance", CollisionDesc::Distance::Exact,
                       {{"exact", CollisionDesc::Distance::Exact}, {"grid", CollisionDesc::Distance::Grid}});
        s.collision.friction = c.number("friction", s.collision.friction, 0, 1);
        s.collision.restitution = c.number("restitution", s.collision.restitution, 0, 1);
    });


    r.array("objects", [&](ObjectReader& o, int i) { s.objects.push_back(readObject(o, i, sceneDir)); });
    r.array("curves", [&](ObjectReader& c, int i) { s.curves.push_back(readCurve(c, i, sceneDir)); });
    for (std::size_t i = 0; i < s.curves.size(); ++i)
        for (std::size_t j = 0; j < i; ++j)
            if (s.curves[i].name == s.curves[j].name)
                throw InputError(file, "curves[" + std::to_string(i) + "].name",
                                 "duplicate curve name \"" + s.curves[i].name + "\"");
    if (!s.curves.empty() && s.curves.size() != 2)
        r.fail("curves",
               "expected exactly 2 curves (their linking number is measured), got " + std::to_string(s.curves.size()));
    if (!s.curves.empty() && !s.objects.empty())
        r.fail("curves", "a scene has either objects or curves, not both (not supported yet)");
    r.object("gln", [&](ObjectReader& g) {
        if (const Json* t = g.get("seed_tolerances")) {
            if (!t->is_array()) g.fail("seed_tolerances", "expected an array of positive numbers, got " + describe(*t));
            s.gln.seedTolerances.clear();
            for (std::size_t k = 0; k < t->size(); ++k)
                s.gln.seedTolerances.push_back(
                    g.checkNumber("seed_tolerances[" + std::to_string(k) + "]", (*t)[k], 0, 50.0 / 3, true));
        }
    });
    if (s.objects.empty() && s.curves.empty()) r.fail("objects", "a scene needs at least one object");
    for (std::size_t i = 0; i < s.objects.size(); ++i)
        for (std::size_t j = 0; j < i; ++j)
            if (s.objects[i].name == s.objects[j].name)
                throw InputError(file, "objects[" + std::to_string(i) + "].name",
                                 "duplicate object name \"" + s.objects[i].name + "\"");

    r.array("forces", [&](ObjectReader& f, int) { s.forces.push_back(readForce(f)); });
    r.array("colliders", [&](ObjectReader& c, int) { s.colliders.push_back(readCollider(c, sceneDir)); });
    r.object("camera", [&](ObjectReader& c) { readCamera(c, s.camera); });
    r.object("render", [&](ObjectReader& g) { readRender(g, s.render, sceneDir); });

    std::string outDir = "out/" + s.name;
    r.object("output", [&](ObjectReader& o) {
        outDir = o.string("dir", outDir);
        s.output.vdb = o.boolean("vdb", false);
        s.output.vdbVoxelSize = o.number("vdb_voxel_size", 0, 0, HUGE_VAL);
        s.output.vdbHalf = o.boolean("vdb_half", false);
        s.output.vdbSurface = o.boolean("vdb_surface", false);
        if (o.has("mesh")) {
            const Json* m = o.get("mesh");
            if (m->is_boolean() && !m->get<bool>())
                s.output.mesh.clear();
            else
                s.output.mesh = o.choice("mesh", "", {"ply", "obj", "gltf"});
        }
    });
    if (outDir.rfind("//", 0) == 0)
        s.output.dir = (sceneDir / outDir.substr(2)).lexically_normal().string();
    else
        s.output.dir = fs::absolute(outDir).lexically_normal().string();

    r.finish();
    return s;
}

SceneDesc loadScene(const fs::path& path) {
    // meshes and level sets are separate files a scene names: 64 MiB of JSON is plenty
    constexpr std::uintmax_t kMaxSceneBytes = 64u << 20;
    return parseScene(readInputFile(path, "scene file", kMaxSceneBytes), path);
}

}  // namespace dgv
