// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_CORE_SCENE_HPP
#define OPENCV_VBME_CORE_SCENE_HPP

#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "opencv2/vbme/core/camera.hpp"

namespace cv {
namespace vbme {

//! @addtogroup vbme_core
//! @{

/** @brief A material of the scene file (DESIGN, "Scene / annotation file").

Colours are linear RGB; roughness is the microfacet α, not a perceptual value. Only the fields
of the chosen type are meaningful; the others keep their defaults and are not written.
*/
struct CV_EXPORTS Material {
    /** @brief Material model. */
    enum Type {
        LAMBERTIAN,     //!< `albedo`
        PHONG,          //!< `kd, ks, exponent` (energy-conserving normalisation)
        COOK_TORRANCE,  //!< `kd, ks, roughness, ior` (Beckmann)
        CONDUCTOR,      //!< `eta, k` or `colour`, `roughness` (GGX; mirror at 0)
        DIELECTRIC,     //!< `ior, roughness, absorption` (per metre)
        PLASTIC,        //!< `albedo, ior, roughness`
        EMISSIVE        //!< `radiance`
    };
    Type type = LAMBERTIAN;               //!< the model
    Vec3d albedo = Vec3d(0.8, 0.8, 0.8);  //!< lambertian / plastic diffuse colour
    Vec3d kd = Vec3d(0.5, 0.5, 0.5);      //!< phong / cook_torrance diffuse colour
    Vec3d ks = Vec3d(0.5, 0.5, 0.5);      //!< phong / cook_torrance specular colour
    double exponent = 50;                 //!< phong exponent
    double roughness = 0;                 //!< microfacet α
    double ior = 1.5;               //!< index of refraction (dielectric, plastic, cook_torrance)
    Vec3d eta = Vec3d(0, 0, 0);     //!< conductor complex IOR, real part (RGB)
    Vec3d k = Vec3d(0, 0, 0);       //!< conductor complex IOR, imaginary part (RGB)
    bool use_colour = false;        //!< conductor given by reflectance `colour` instead of eta/k
    Vec3d colour = Vec3d(1, 1, 1);  //!< conductor reflectance at normal incidence
    Vec3d absorption = Vec3d(0, 0, 0);  //!< dielectric Beer–Lambert absorption per metre
    Vec3d radiance = Vec3d(0, 0, 0);    //!< emissive radiance

    /** @brief Named presets: chrome, gold, copper, silver, mirror, glass, ice, blue, red,
    matte, white. Throws cv::Exception listing them for an unknown name. */
    static Material preset(const std::string& name);
    /** @brief Names accepted by preset(). */
    static std::vector<std::string> presetNames();
    /** @brief Parses a type name ("lambertian", …). @p field names the place in the file for
    the error message. */
    static Type parseType(const std::string& name, const std::string& field = "material.type");
    /** @brief The file name of a type. */
    static std::string typeName(Type t);

    /** @brief Writes the material as a map body (`type` and the fields of that type). */
    void write(FileStorage& fs) const;
    /** @brief Reads a material: a map with `type` (or `preset`) and that type's fields, or a
    plain string naming a preset. @p field names the node for error messages. */
    void read(const FileNode& node, const std::string& field = "material");
};

/** @brief A light of the scene file. */
struct CV_EXPORTS Light {
    /** @brief Light type. */
    enum Type {
        POLYGON,     //!< planar emitter, `corners` wound CCW seen from the lit side
        POINT,       //!< `position`, `intensity` (W/sr)
        DISTANT,     //!< `to_light`, `radiance`, `half_angle_deg`
        ENVIRONMENT  //!< constant `radiance`, or an equirectangular `image`
    };
    Type type = POINT;                        //!< the type
    std::vector<Vec3d> corners;               //!< polygon corners (world, metres)
    Vec3d radiance = Vec3d(1, 1, 1);          //!< polygon / distant / constant environment
    Vec3d position = Vec3d(0, 0, 0);          //!< point light position
    Vec3d intensity = Vec3d(1, 1, 1);         //!< point light radiant intensity
    Vec3d to_light = Vec3d(0, 0, 1);          //!< distant light direction (towards the light)
    double half_angle_deg = 0;                //!< distant light opening half-angle
    std::string image;                        //!< environment image (absolute path once read)
    double scale = 1;                         //!< environment image scale
    Matx33d world_from_env = Matx33d::eye();  //!< environment rotation

    /** @brief Parses a type name ("polygon", "point", "distant", "environment"). */
    static Type parseType(const std::string& name, const std::string& field = "light.type");
    /** @brief The file name of a type. */
    static std::string typeName(Type t);
    /** @brief Unit normal of a polygon light (from its winding), pointing to the lit side. */
    Vec3d polygonNormal() const;
};

/** @brief A mesh placed in the world: an object to insert or a proxy of a real thing. */
struct CV_EXPORTS SceneObject {
    std::string mesh;                            //!< mesh file (absolute path once read)
    Matx44d world_from_object = Matx44d::eye();  //!< placement
    bool has_material = false;                   //!< false: the mesh's own MTL materials
    Material material;                           //!< override material when has_material
};

/** @brief A face of the room box seen from inside: the rectangle bl + u·right + v·up,
u, v ∈ [0, 1] (world, metres), and its unit normal n = right × up / |right × up|, pointing into
the room.

This is the orientation of the face's texture: texel (col, row) of a W×H texture lies at
u = (col + ½)/W, v = 1 − (row + ½)/H, so the image's top row is at the face's top (up) and
its left column at bl. Every module uses this one table (Room::face()): the renderer's room
geometry, the room textures, albedo and light estimation. */
template <typename T>
struct RoomFace_ {
    Vec<T, 3> bl;     //!< bottom-left corner (u = v = 0)
    Vec<T, 3> right;  //!< edge along u (image right)
    Vec<T, 3> up;     //!< edge along v (image up)
    Vec<T, 3> n;      //!< unit normal into the room
};
typedef RoomFace_<double> RoomFace;  //!< the face in double precision

/** @brief The room box, axis-aligned in world coordinates. */
struct CV_EXPORTS Room {
    Vec3d min = Vec3d(0, 0, 0);  //!< minimum corner (floor at min z)
    Vec3d max = Vec3d(1, 1, 1);  //!< maximum corner
    /** @brief Face name (floor, ceiling, left, right, front, back) → texture path. */
    std::map<std::string, std::string> textures;
    /** @brief The six face names in DESIGN order. */
    static const std::vector<std::string>& faceNames();
    /** @brief Index of @p name in faceNames(), or -1 when it is not a face name. */
    static int findFace(const std::string& name);
    /** @brief Index of @p name in faceNames(); throws cv::Exception (StsBadArg) naming the valid
    names when it is not a face name. */
    static int faceIndex(const std::string& name);
    /** @brief The world axis face @p i (faceNames() order) is perpendicular to: 2 (z) for floor
    and ceiling, 0 (x) for left and right, 1 (y) for front and back. */
    static int faceAxis(int i);
    /** @brief Face @p i (faceNames() order) as seen from inside, computed in precision @p T
    (float for the renderer's geometry, double elsewhere). Throws for i outside 0…5. */
    template <typename T = double>
    RoomFace_<T> face(int i) const;
};

template <typename T>
RoomFace_<T> Room::face(int i) const {
    typedef Vec<T, 3> V;
    const V lo(min), hi(max);
    const V ex(hi[0] - lo[0], 0, 0), ey(0, hi[1] - lo[1], 0), ez(0, 0, hi[2] - lo[2]);
    RoomFace_<T> F;
    switch (i) {
        case 0:
            F = {lo, ex, ey, V()};
            break;  // floor
        case 1:
            F = {V(lo[0], hi[1], hi[2]), ex, -ey, V()};
            break;  // ceiling
        case 2:
            F = {lo, ey, ez, V()};
            break;  // left
        case 3:
            F = {V(hi[0], hi[1], lo[2]), -ey, ez, V()};
            break;  // right
        case 4:
            F = {V(hi[0], lo[1], lo[2]), -ex, ez, V()};
            break;  // front
        case 5:
            F = {V(lo[0], hi[1], lo[2]), ex, ez, V()};
            break;  // back
        default:
            CV_Error(Error::StsOutOfRange,
                     cv::format("Room::face: index %d, expected 0…5 (faceNames() order)", i));
    }
    F.n = normalize(F.right.cross(F.up));
    return F;
}

/** @name Limits of the file readers
Scene, camera-path and annotation files asking for more are refused with a message (a typo
such as a 10⁶ × 10⁶ image or 10⁹ samples per pixel would otherwise allocate or run for ever).
@{ */
constexpr int kSceneMaxImageSide = 32768;      //!< width or height, pixels
constexpr int kSceneMaxImagePixels = 1 << 27;  //!< width × height (134 Mpixel)
constexpr int kSceneMaxSpp = 1 << 16;          //!< render.spp
constexpr int kSceneMaxDepth = 1024;           //!< render.max_depth
/** @} */

/** @brief Render settings of the scene file. */
struct CV_EXPORTS RenderSettings {
    int spp = 32;       //!< samples per pixel
    int max_depth = 8;  //!< maximum path length
    uint64 seed = 0;    //!< seed of the deterministic sampler
};

/** @brief A frame's scene: the contract between calibrate, track-camera, render and insert.

Read and written with cv::FileStorage (YAML or JSON, by extension). Paths inside the file are
relative to the file (absolute allowed); read() turns them into absolute paths, write() writes
them relative to the new file where they lie below its folder.
*/
struct CV_EXPORTS Scene {
    Size image_size;                   //!< image size of the camera
    Camera camera;                     //!< camera of this frame
    bool has_room = false;             //!< whether `room` is present
    Room room;                         //!< the room box
    std::vector<Light> lights;         //!< light sources
    std::vector<SceneObject> objects;  //!< synthetic objects being inserted
    std::vector<SceneObject> proxies;  //!< stand-ins for real geometry (in both passes)
    RenderSettings render;             //!< render settings

    /** @brief Reads a scene file. Throws cv::Exception naming the file and field at fault. */
    static Scene read(const std::string& path);
    /** @brief Things that are valid but probably not what the user meant, one sentence each
    (e.g. a polygon light on the room box that faces out of the room, so it lights nothing
    inside). Empty when nothing looks wrong. */
    std::vector<std::string> warnings() const;
    /** @brief Writes the scene to @p path (YAML or JSON by extension), under a temporary
    name renamed when complete. */
    void write(const std::string& path) const;
};

/** @brief Reads a material file: one top-level `material:` map (or preset name). */
CV_EXPORTS Material readMaterialFile(const std::string& path);
/** @brief Writes a material file with one top-level `material:` map. */
CV_EXPORTS void writeMaterialFile(const std::string& path, const Material& m);

/** @name FileStorage helpers shared by the file readers
Matrices are accepted as `!!opencv-matrix`, nested sequences or flat sequences; vectors as
flow sequences. On error they throw cv::Exception naming @p field.
@{ */
/** @brief Reads a 3-vector. */
CV_EXPORTS Vec3d readVec3(const FileNode& node, const std::string& field);
/** @brief Reads a rows×cols matrix of doubles. */
CV_EXPORTS Mat readMatrix(const FileNode& node, int rows, int cols, const std::string& field);
/** @brief Reads an image size `[width, height]`: positive integers within
kSceneMaxImageSide and kSceneMaxImagePixels. */
CV_EXPORTS Size readImageSize(const FileNode& node, const std::string& field);
/** @brief Writes a 3-vector as a flow sequence under @p key. */
CV_EXPORTS void writeVec3(FileStorage& fs, const std::string& key, const Vec3d& v);
/** @} */

//! @}

}  // namespace vbme
}  // namespace cv

#endif
