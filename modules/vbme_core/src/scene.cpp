// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#include "opencv2/vbme/core/scene.hpp"

#include <algorithm>
#include <cmath>

#include "opencv2/vbme/core/fileio.hpp"

namespace cv {
namespace vbme {

// ---------------------------------------------------------------- FileStorage helpers

static void collectNumbers(const FileNode& n, std::vector<double>& out, const std::string& field) {
    if (n.isSeq()) {
        for (FileNodeIterator it = n.begin(); it != n.end(); ++it)
            collectNumbers(*it, out, field);
    } else if (n.isReal() || n.isInt()) {
        out.push_back((double)n);
    } else {
        CV_Error(Error::StsParseError, field + ": expected numbers");
    }
}

Mat readMatrix(const FileNode& node, int rows, int cols, const std::string& field) {
    if (node.empty() || node.isNone())
        CV_Error(Error::StsParseError, field + ": missing (expected a " + std::to_string(rows) +
                                           "x" + std::to_string(cols) + " matrix)");
    Mat m;
    if (node.isMap()) {
        // the header first: OpenCV allocates rows x cols before it reads the data, so a typo
        // in rows or cols could ask for gigabytes
        const FileNode nr = node["rows"], nc = node["cols"];
        if (!nr.isInt() || !nc.isInt() || (int)nr < 1 || (int)nc < 1 ||
            (int64)(int)nr * (int)nc != (int64)rows * cols)
            CV_Error(Error::StsParseError,
                     format("%s: expected a %dx%d !!opencv-matrix (rows: %d, cols: %d)",
                            field.c_str(), rows, cols, rows, cols));
        try {
            node >> m;
        } catch (const cv::Exception&) {
            m.release();
        }
        if (m.empty()) CV_Error(Error::StsParseError, field + ": not a readable !!opencv-matrix");
        m.convertTo(m, CV_64F);
    } else {
        std::vector<double> v;
        collectNumbers(node, v, field);
        m = Mat(v, true);
    }
    if ((int)m.total() != rows * cols)
        CV_Error(Error::StsParseError, format("%s: expected %dx%d values, found %d", field.c_str(),
                                              rows, cols, (int)m.total()));
    m = m.reshape(1, rows).clone();
    for (int i = 0; i < rows * cols; ++i)
        if (!std::isfinite(m.at<double>(i)))
            CV_Error(Error::StsParseError, field + ": contains a non-finite value");
    return m;
}

Vec3d readVec3(const FileNode& node, const std::string& field) {
    return Vec3d(readMatrix(node, 3, 1, field));
}

void writeVec3(FileStorage& fs, const std::string& key, const Vec3d& v) {
    fs << key << "[:" << v[0] << v[1] << v[2] << "]";
}

static double readNumber(const FileNode& n, const std::string& field, double def) {
    if (n.empty() || n.isNone()) return def;
    if (!n.isReal() && !n.isInt()) CV_Error(Error::StsParseError, field + ": expected a number");
    return (double)n;
}

// An integer setting in [lo, hi]: a value out of range is refused before any conversion (a
// double beyond the integer's range has no defined conversion).
static double readIntegral(const FileNode& n, const std::string& field, double def, double lo,
                           double hi) {
    const double v = readNumber(n, field, def);
    if (!(v >= lo && v <= hi) || v != std::floor(v))
        CV_Error(Error::StsBadArg,
                 format("%s: %.17g is not an integer in [%.17g, %.17g]", field.c_str(), v, lo, hi));
    return v;
}

static Vec3d readVec3Or(const FileNode& n, const std::string& field, const Vec3d& def) {
    if (n.empty() || n.isNone()) return def;
    return readVec3(n, field);
}

static std::string readString(const FileNode& n, const std::string& field) {
    if (n.empty() || !n.isString()) CV_Error(Error::StsParseError, field + ": expected a string");
    return (std::string)n;
}

// ---------------------------------------------------------------- Material

static const char* kMaterialTypes[] = {"lambertian", "phong",   "cook_torrance", "conductor",
                                       "dielectric", "plastic", "emissive"};

Material::Type Material::parseType(const std::string& name, const std::string& field) {
    for (int i = 0; i < 7; ++i)
        if (name == kMaterialTypes[i]) return Type(i);
    CV_Error(Error::StsBadArg, field + ": unknown material type '" + name +
                                   "' (expected lambertian, phong, cook_torrance, conductor, "
                                   "dielectric, plastic or emissive)");
}

std::string Material::typeName(Type t) {
    return kMaterialTypes[int(t)];
}

std::vector<std::string> Material::presetNames() {
    return {"chrome", "gold", "copper", "silver", "mirror", "glass",
            "ice",    "blue", "red",    "matte",  "white"};
}

Material Material::preset(const std::string& name) {
    Material m;
    if (name == "chrome" || name == "gold" || name == "copper" || name == "silver") {
        m.type = CONDUCTOR;
        m.roughness = 0.02;
        // Complex refractive indices at ~650/550/450 nm (R, G, B), from published tables.
        if (name == "chrome") {
            m.eta = Vec3d(3.11, 3.18, 2.33);
            m.k = Vec3d(3.31, 3.33, 3.14);
        } else if (name == "gold") {
            m.eta = Vec3d(0.143, 0.374, 1.442);
            m.k = Vec3d(3.983, 2.385, 1.603);
        } else if (name == "copper") {
            m.eta = Vec3d(0.200, 0.924, 1.102);
            m.k = Vec3d(3.912, 2.452, 2.142);
        } else {
            m.eta = Vec3d(0.155, 0.117, 0.138);
            m.k = Vec3d(4.828, 3.122, 2.147);
        }
    } else if (name == "mirror") {
        m.type = CONDUCTOR;
        m.use_colour = true;
        m.colour = Vec3d(0.95, 0.95, 0.95);
        m.roughness = 0;
    } else if (name == "glass") {
        m.type = DIELECTRIC;
        m.ior = 1.5;
    } else if (name == "ice") {
        m.type = DIELECTRIC;
        m.ior = 1.31;
        m.roughness = 0.05;
        m.absorption = Vec3d(0.8, 0.3, 0.1);  // ice absorbs red most: a faint blue tint
    } else if (name == "blue" || name == "red") {
        m.type = PLASTIC;
        m.albedo = name == "blue" ? Vec3d(0.03, 0.08, 0.45) : Vec3d(0.5, 0.03, 0.03);
        m.ior = 1.5;
        m.roughness = 0.05;
    } else if (name == "matte" || name == "white") {
        m.type = LAMBERTIAN;
        m.albedo = name == "matte" ? Vec3d(0.5, 0.5, 0.5) : Vec3d(0.8, 0.8, 0.8);
    } else {
        std::string list;
        for (const auto& n : presetNames())
            list += (list.empty() ? "" : ", ") + n;
        CV_Error(Error::StsBadArg,
                 "unknown material preset '" + name + "' (expected " + list + ")");
    }
    return m;
}

void Material::write(FileStorage& fs) const {
    fs << "type" << typeName(type);
    switch (type) {
        case LAMBERTIAN:
            writeVec3(fs, "albedo", albedo);
            break;
        case PHONG:
            writeVec3(fs, "kd", kd);
            writeVec3(fs, "ks", ks);
            fs << "exponent" << exponent;
            break;
        case COOK_TORRANCE:
            writeVec3(fs, "kd", kd);
            writeVec3(fs, "ks", ks);
            fs << "roughness" << roughness << "ior" << ior;
            break;
        case CONDUCTOR:
            if (use_colour) {
                writeVec3(fs, "colour", colour);
            } else {
                writeVec3(fs, "eta", eta);
                writeVec3(fs, "k", k);
            }
            fs << "roughness" << roughness;
            break;
        case DIELECTRIC:
            fs << "ior" << ior << "roughness" << roughness;
            writeVec3(fs, "absorption", absorption);
            break;
        case PLASTIC:
            writeVec3(fs, "albedo", albedo);
            fs << "ior" << ior << "roughness" << roughness;
            break;
        case EMISSIVE:
            writeVec3(fs, "radiance", radiance);
            break;
    }
}

void Material::read(const FileNode& node, const std::string& field) {
    if (node.isString()) {
        *this = preset((std::string)node);
        return;
    }
    if (!node.isMap()) CV_Error(Error::StsParseError, field + ": expected a map or a preset name");
    if (!node["preset"].empty()) {
        *this = preset(readString(node["preset"], field + ".preset"));
    } else {
        *this = Material();
        type = parseType(readString(node["type"], field + ".type"), field + ".type");
        if (type == DIELECTRIC || type == PLASTIC) roughness = 0;
    }
    albedo = readVec3Or(node["albedo"], field + ".albedo", albedo);
    kd = readVec3Or(node["kd"], field + ".kd", kd);
    ks = readVec3Or(node["ks"], field + ".ks", ks);
    exponent = readNumber(node["exponent"], field + ".exponent", exponent);
    roughness = readNumber(node["roughness"], field + ".roughness", roughness);
    ior = readNumber(node["ior"], field + ".ior", ior);
    eta = readVec3Or(node["eta"], field + ".eta", eta);
    k = readVec3Or(node["k"], field + ".k", k);
    if (!node["colour"].empty() || !node["color"].empty()) {
        use_colour = true;
        colour =
            readVec3(node["colour"].empty() ? node["color"] : node["colour"], field + ".colour");
    }
    absorption = readVec3Or(node["absorption"], field + ".absorption", absorption);
    radiance = readVec3Or(node["radiance"], field + ".radiance", radiance);
    if (type == CONDUCTOR && !use_colour && eta == Vec3d(0, 0, 0) && k == Vec3d(0, 0, 0))
        CV_Error(Error::StsParseError, field + ": a conductor needs eta and k, or colour");
    if (roughness < 0) CV_Error(Error::StsBadArg, field + ".roughness: must be >= 0");
    if (ior <= 0) CV_Error(Error::StsBadArg, field + ".ior: must be > 0");
}

Material readMaterialFile(const std::string& path) {
    FileStorage fs = openForReading(path, "material file");
    if (!fs.root().isMap())
        CV_Error(Error::StsParseError, path + ": expected a map with a top-level 'material'");
    FileNode n = fs["material"];
    if (n.empty()) CV_Error(Error::StsParseError, path + ": missing top-level 'material'");
    Material m;
    try {
        m.read(n, "material");
    } catch (const cv::Exception& e) {
        CV_Error(Error::StsParseError, path + ": " + e.err);
    }
    return m;
}

void writeMaterialFile(const std::string& path, const Material& m) {
    AtomicFile out(path);
    {
        FileStorage fs = openForWriting(out);
        fs << "material"
           << "{";
        m.write(fs);
        fs << "}";
    }
    out.commit();
}

// ---------------------------------------------------------------- Light

static const char* kLightTypes[] = {"polygon", "point", "distant", "environment"};

Light::Type Light::parseType(const std::string& name, const std::string& field) {
    for (int i = 0; i < 4; ++i)
        if (name == kLightTypes[i]) return Type(i);
    CV_Error(Error::StsBadArg, field + ": unknown light type '" + name +
                                   "' (expected polygon, point, distant or environment)");
}

std::string Light::typeName(Type t) {
    return kLightTypes[int(t)];
}

Vec3d Light::polygonNormal() const {
    // Newell's method: robust for any planar polygon, follows the winding.
    Vec3d n(0, 0, 0);
    for (size_t i = 0; i < corners.size(); ++i) {
        const Vec3d& a = corners[i];
        const Vec3d& b = corners[(i + 1) % corners.size()];
        n += a.cross(b);
    }
    const double len = norm(n);
    return len > 0 ? n / len : n;
}

const std::vector<std::string>& Room::faceNames() {
    static const std::vector<std::string> names = {"floor", "ceiling", "left",
                                                   "right", "front",   "back"};
    return names;
}

int Room::findFace(const std::string& name) {
    const std::vector<std::string>& f = faceNames();
    for (int i = 0; i < (int)f.size(); ++i)
        if (f[i] == name) return i;
    return -1;
}

int Room::faceIndex(const std::string& name) {
    const int i = findFace(name);
    if (i < 0)
        CV_Error(Error::StsBadArg,
                 "room face '" + name + "' is not one of floor, ceiling, left, right, front, back");
    return i;
}

int Room::faceAxis(int i) {
    if (i < 0 || i > 5)
        CV_Error(Error::StsOutOfRange,
                 cv::format("Room::faceAxis: index %d, expected 0…5 (faceNames() order)", i));
    return i <= 1 ? 2 : (i <= 3 ? 0 : 1);
}

// ---------------------------------------------------------------- Scene

Size readImageSize(const FileNode& node, const std::string& field) {
    Mat sz = readMatrix(node, 2, 1, field);
    const double w = sz.at<double>(0), h = sz.at<double>(1);
    if (!(w >= 1 && h >= 1) || w != std::floor(w) || h != std::floor(h))
        CV_Error(Error::StsBadArg,
                 format("%s: [%.17g, %.17g] is not a positive integer size [width, height]",
                        field.c_str(), w, h));
    if (w > kSceneMaxImageSide || h > kSceneMaxImageSide || w * h > kSceneMaxImagePixels)
        CV_Error(Error::StsBadArg,
                 format("%s: %.17g x %.17g is too large (vbme accepts at most %d pixels a side "
                        "and %d pixels in all)",
                        field.c_str(), w, h, kSceneMaxImageSide, kSceneMaxImagePixels));
    return Size((int)w, (int)h);
}

static void readObjects(const FileNode& seq, const std::string& key, const std::string& base,
                        std::vector<SceneObject>& out) {
    if (seq.empty() || seq.isNone()) return;
    if (!seq.isSeq()) CV_Error(Error::StsParseError, key + ": expected a sequence");
    int i = 0;
    for (FileNodeIterator it = seq.begin(); it != seq.end(); ++it, ++i) {
        const std::string f = key + "[" + std::to_string(i) + "]";
        const FileNode n = *it;
        SceneObject o;
        o.mesh = resolvePath(base, readString(n["mesh"], f + ".mesh"));
        if (!n["world_from_object"].empty()) {
            o.world_from_object =
                Matx44d(readMatrix(n["world_from_object"], 4, 4, f + ".world_from_object"));
            Matx33d A;
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c)
                    A(r, c) = o.world_from_object(r, c);
            if (std::abs(determinant(A)) < 1e-12)
                CV_Error(Error::StsBadArg, f + ".world_from_object: not invertible");
        }
        if (!n["material"].empty()) {
            o.has_material = true;
            o.material.read(n["material"], f + ".material");
        }
        out.push_back(o);
    }
}

static void writeObjects(FileStorage& fs, const std::string& key, const std::string& base,
                         const std::vector<SceneObject>& objs) {
    writeMapSeq(fs, key, objs, [&](const SceneObject& o) {
        fs << "mesh" << relativePath(base, o.mesh);
        fs << "world_from_object" << Mat(o.world_from_object);
        if (o.has_material) {
            fs << "material"
               << "{";
            o.material.write(fs);
            fs << "}";
        }
    });
}

static Scene readSceneImpl(const FileStorage& fs, const std::string& base) {
    Scene s;
    const FileNode root = fs.root();
    s.image_size = readImageSize(root["image_size"], "image_size");
    s.camera.read(root["camera"]);
    s.camera.image_size = s.image_size;

    const FileNode room = root["room"];
    if (!room.empty() && !room.isNone()) {
        s.has_room = true;
        s.room.min = readVec3(room["min"], "room.min");
        s.room.max = readVec3(room["max"], "room.max");
        for (int a = 0; a < 3; ++a)
            if (!(s.room.max[a] > s.room.min[a]))
                CV_Error(Error::StsBadArg, "room: max must exceed min on every axis");
        const FileNode tex = room["textures"];
        if (!tex.empty() && !tex.isNone()) {
            for (const auto& face : Room::faceNames())
                if (!tex[face].empty())
                    s.room.textures[face] =
                        resolvePath(base, readString(tex[face], "room.textures." + face));
            for (FileNodeIterator it = tex.begin(); it != tex.end(); ++it) {
                const std::string name = (*it).name();
                if (std::find(Room::faceNames().begin(), Room::faceNames().end(), name) ==
                    Room::faceNames().end())
                    CV_Error(Error::StsBadArg, "room.textures." + name +
                                                   ": unknown face (expected floor, ceiling, "
                                                   "left, right, front or back)");
            }
        }
    }

    const FileNode lights = root["lights"];
    if (!lights.empty() && !lights.isNone()) {
        if (!lights.isSeq()) CV_Error(Error::StsParseError, "lights: expected a sequence");
        int i = 0;
        for (FileNodeIterator it = lights.begin(); it != lights.end(); ++it, ++i) {
            const std::string f = "lights[" + std::to_string(i) + "]";
            const FileNode n = *it;
            Light l;
            l.type = Light::parseType(readString(n["type"], f + ".type"), f + ".type");
            switch (l.type) {
                case Light::POLYGON: {
                    const FileNode c = n["corners"];
                    if (!c.isSeq() || c.size() < 3)
                        CV_Error(Error::StsParseError, f + ".corners: expected >= 3 points");
                    int j = 0;
                    for (FileNodeIterator ci = c.begin(); ci != c.end(); ++ci, ++j)
                        l.corners.push_back(
                            readVec3(*ci, f + ".corners[" + std::to_string(j) + "]"));
                    if (norm(l.polygonNormal()) == 0)
                        CV_Error(Error::StsBadArg, f + ".corners: degenerate polygon (no area)");
                    l.radiance = readVec3(n["radiance"], f + ".radiance");
                    break;
                }
                case Light::POINT:
                    l.position = readVec3(n["position"], f + ".position");
                    l.intensity = readVec3(n["intensity"], f + ".intensity");
                    break;
                case Light::DISTANT:
                    l.to_light = readVec3(n["to_light"], f + ".to_light");
                    if (norm(l.to_light) == 0)
                        CV_Error(Error::StsBadArg, f + ".to_light: must be non-zero");
                    l.to_light = normalize(l.to_light);
                    l.radiance = readVec3(n["radiance"], f + ".radiance");
                    l.half_angle_deg = readNumber(n["half_angle_deg"], f + ".half_angle_deg", 0);
                    break;
                case Light::ENVIRONMENT:
                    if (!n["image"].empty()) {
                        l.image = resolvePath(base, readString(n["image"], f + ".image"));
                        l.scale = readNumber(n["scale"], f + ".scale", 1);
                        if (!n["world_from_env"].empty())
                            l.world_from_env = Matx33d(
                                readMatrix(n["world_from_env"], 3, 3, f + ".world_from_env"));
                    } else {
                        l.radiance = readVec3(n["radiance"], f + ".radiance");
                    }
                    break;
            }
            s.lights.push_back(l);
        }
    }
    readObjects(root["objects"], "objects", base, s.objects);
    readObjects(root["proxies"], "proxies", base, s.proxies);

    const FileNode r = root["render"];
    if (!r.empty() && !r.isNone()) {
        s.render.spp = (int)readIntegral(r["spp"], "render.spp", s.render.spp, 1, kSceneMaxSpp);
        s.render.max_depth = (int)readIntegral(r["max_depth"], "render.max_depth",
                                               s.render.max_depth, 1, kSceneMaxDepth);
        // seeds above 2^31 are written as reals, exact up to 2^53
        s.render.seed = (uint64)readIntegral(r["seed"], "render.seed", (double)s.render.seed, 0,
                                             9007199254740992.0);
    }
    return s;
}

std::vector<std::string> Scene::warnings() const {
    std::vector<std::string> w;
    if (!has_room) return w;
    const Vec3d centre = (room.min + room.max) * 0.5;
    for (size_t i = 0; i < lights.size(); ++i) {
        const Light& l = lights[i];
        if (l.type != Light::POLYGON || l.corners.empty()) continue;
        Vec3d c(0, 0, 0);
        for (const auto& p : l.corners)
            c += p;
        c *= 1.0 / l.corners.size();
        if (l.polygonNormal().dot(centre - c) < 0)
            w.push_back(format(
                "lights[%d]: the polygon faces out of the room (its corners run clockwise "
                "seen from inside), so it lights nothing in the room; reverse the corner order",
                (int)i));
    }
    return w;
}

Scene Scene::read(const std::string& path) {
    FileStorage fs = openForReading(path, "scene file");
    try {
        return readSceneImpl(fs, parentFolder(path));
    } catch (const cv::Exception& e) {
        CV_Error(e.code, path + ": " + e.err);
    }
}

void Scene::write(const std::string& path) const {
    const std::string base = parentFolder(path);
    AtomicFile out(path);
    {
        FileStorage fs = openForWriting(out);
        fs << "image_size"
           << "[:" << image_size.width << image_size.height << "]";
        fs << "camera"
           << "{";
        camera.write(fs);
        fs << "}";
        if (has_room) {
            fs << "room"
               << "{";
            writeVec3(fs, "min", room.min);
            writeVec3(fs, "max", room.max);
            if (!room.textures.empty()) {
                fs << "textures"
                   << "{";
                for (const auto& kv : room.textures)
                    fs << kv.first << relativePath(base, kv.second);
                fs << "}";
            }
            fs << "}";
        }
        writeMapSeq(fs, "lights", lights, [&](const Light& l) {
            fs << "type" << Light::typeName(l.type);
            switch (l.type) {
                case Light::POLYGON:
                    fs << "corners"
                       << "[";
                    for (const auto& c : l.corners)
                        fs << "[:" << c[0] << c[1] << c[2] << "]";
                    fs << "]";
                    writeVec3(fs, "radiance", l.radiance);
                    break;
                case Light::POINT:
                    writeVec3(fs, "position", l.position);
                    writeVec3(fs, "intensity", l.intensity);
                    break;
                case Light::DISTANT:
                    writeVec3(fs, "to_light", l.to_light);
                    writeVec3(fs, "radiance", l.radiance);
                    fs << "half_angle_deg" << l.half_angle_deg;
                    break;
                case Light::ENVIRONMENT:
                    if (!l.image.empty()) {
                        fs << "image" << relativePath(base, l.image) << "scale" << l.scale;
                        fs << "world_from_env" << Mat(l.world_from_env);
                    } else {
                        writeVec3(fs, "radiance", l.radiance);
                    }
                    break;
            }
        });
        writeObjects(fs, "objects", base, objects);
        writeObjects(fs, "proxies", base, proxies);
        fs << "render"
           << "{"
           << "spp" << render.spp << "max_depth" << render.max_depth;
        // FileStorage stores 32-bit integers; larger seeds go out as reals (exact to 2^53).
        if (render.seed <= 0x7fffffffu)
            fs << "seed" << (int)render.seed;
        else
            fs << "seed" << (double)render.seed;
        fs << "}";
    }
    out.commit();
}

}  // namespace vbme
}  // namespace cv
