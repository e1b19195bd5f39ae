#pragma once
// Reading and writing meshes and point clouds: PLY (ASCII, binary little and big endian), OBJ, OFF
// and STL (ASCII and binary); point clouds also as PCD (the Point Cloud Library's format, ASCII and
// binary; pcd.cpp), XYZ and PTS (text; xyz.cpp).
//
// Contract for every reader: the format is chosen by the file's extension (case-insensitive) and
// checked against the file's magic. Any problem — missing path, directory, unreadable or empty file,
// unknown format, bad magic, truncated data, wrong element counts, out-of-range indices, NaN/Inf
// coordinates or normals, counts larger than the file could hold, binary garbage — throws
// InputError whose message starts with the path and says what is wrong (with the line number for
// ASCII formats). Readers never allocate more than the file size justifies.
//
// Contract for every writer: the file is written through write_file_atomic (temporary file, then
// rename): on any error nothing is left at `path`. Bad arguments (unknown extension, attribute
// sizes that do not match, names PLY cannot hold) throw InputError before anything is written.
#include <filesystem>
#include <string>
#include <vector>

#include "autoscan/core/mesh.hpp"
#include "autoscan/core/point_cloud.hpp"

namespace autoscan::io {

enum class FileFormat { ply, obj, off, stl, pcd, xyz, pts };

/// The format named by `path`'s extension (.ply .obj .off .stl .pcd .xyz .pts, any case); throws InputError
/// naming the path for any other extension.
FileFormat format_from_extension(const std::filesystem::path& path);

/// Everything a geometry file holds: its vertices with their attributes (positions, optional
/// normals and colours, named scalars — one entry per vertex) and its faces, fan-triangulated
/// (possibly none, for a point cloud). Indices are validated against the vertex count.
struct GeometryFile {
  PointCloud vertices;
  std::vector<Tri> faces;
  std::string format;           ///< e.g. "ply binary_little_endian", "off", "stl ascii"
  std::size_t polygons = 0;     ///< faces in the file before triangulation
  std::size_t stl_corners = 0;  ///< STL only: corner count before exact welding
  /// OBJ only: the texture coordinates of each triangle's corners (3 per face, after
  /// fan-triangulation), when every face corner names one (`f v/vt ...`); else empty.
  std::vector<Eigen::Vector2d> face_uvs;
  /// OBJ only: the material library named by `mtllib` (as written in the file), and the material of
  /// the first `usemtl` (empty when none).
  std::string material_library, material;
};

/// Reads any supported file. Faces may be empty.
GeometryFile read_geometry(const std::filesystem::path& path);

/// Parses a whole file already in memory as `format`, with every check read_geometry makes (it
/// loads the file and calls this); `name` stands for the path in the messages. Used by the fuzz
/// targets (fuzz/, docs/reliability.md) and by callers that hold the bytes.
GeometryFile parse_geometry(const std::string& bytes, FileFormat format, const std::string& name);

/// The triangle mesh of a geometry file: its vertices with their normals, colours and scalars, and
/// its faces, moved out of `g` (no texture: read_mesh adds an OBJ's). Faces may be empty.
///
/// @param[in,out] g  #V vertices, #F triangles; left without them
/// @return #V by 3 vertices (with #V normals / colours / scalars where `g` had them), #F faces
TriangleMesh mesh_from_geometry(GeometryFile&& g);

/// Reads a triangle mesh (polygons fan-triangulated; STL vertices welded when bit-identical).
/// PLY vertex normals, colours (red green blue) and other scalar vertex properties are kept.
/// An OBJ's vertex colours (`v x y z r g b`) are kept; an OBJ whose faces all carry texture
/// coordinates and that names an `mtllib` gets its texture: the MTL file (next to the OBJ) is read,
/// the `map_Kd` of the material first used (else of the first material) is read as a PNG (relative
/// to the MTL) into mesh.texture with the corner UVs in mesh.face_uvs. A missing or unreadable MTL
/// or texture, a map_Kd that is not a .png, is an InputError naming that file; an MTL without
/// map_Kd leaves the mesh untextured. Throws InputError when the file has no faces.
TriangleMesh read_mesh(const std::filesystem::path& path);

/// Reads a point cloud: a PLY's vertex element (x y z, optional nx ny nz, red green blue, any
/// other scalar property as a named scalar); a PCD file (x y z, optional normal_x normal_y normal_z,
/// rgb/rgba, other fields as named scalars; points whose x, y and z are all NaN, PCL's "no
/// measurement", are dropped); an XYZ file (x y z [nx ny nz]); a PTS file ([count line] x y z
/// [intensity] [r g b]; intensity as the scalar "intensity"); or the vertices of a mesh file.
PointCloud read_point_cloud(const std::filesystem::path& path);

/// How files are written.
struct WriteOptions {
  bool ascii = false;               ///< PLY and STL: text instead of binary (OBJ and OFF are always text)
  bool big_endian = false;          ///< binary PLY: big instead of little endian
  bool double_coordinates = false;  ///< PLY: positions and normals as double instead of float
  bool double_scalars = false;      ///< PLY: named scalars as double instead of float (a column
                                    ///< with a value beyond float's range is double anyway)
};

/// Writes a mesh, format by extension: .ply (vertex normals, colours and named scalars kept),
/// .obj (normals and vertex colours kept; a textured mesh also writes its corner UVs as `vt`, and
/// next to it `<stem>.mtl` naming `<stem>.png`, the texture, each atomically), .off (normals and colours:
/// NOFF/COFF/CNOFF), .stl (geometry only, face normals computed). Throws InputError for an unknown extension, a
/// point-cloud format
/// (.pcd .xyz .pts) or an invalid mesh.
void write_mesh(const std::filesystem::path& path, const TriangleMesh& mesh, const WriteOptions& options = {});

/// Writes a point cloud, format by extension: .ply (normals, colours and every named scalar as a
/// vertex property; MeshLab and CloudCompare show them), .pcd (binary, or ASCII with options.ascii;
/// normals, colours as packed rgb, scalars as fields; float or double as for PLY), .xyz (x y z
/// [nx ny nz]) or .pts (count line, x y z [intensity] [r g b]). Text is written with the shortest
/// decimal that reads back to the same double.
void write_point_cloud(const std::filesystem::path& path, const PointCloud& cloud, const WriteOptions& options = {});

}  // namespace autoscan::io
