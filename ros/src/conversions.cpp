#include "conversions.hpp"

#include <fmt/format.h>
#include <sensor_msgs/PointField.h>
#include <sensor_msgs/image_encodings.h>
#include <std_msgs/ColorRGBA.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>

namespace autoscan_ros {

namespace {

using sensor_msgs::PointField;

// Throws InputError with the formatted message unless `ok`.
template <class... A>
void require(bool ok, fmt::format_string<A...> f, A&&... a) {
  if (!ok) throw InputError(fmt::format(f, std::forward<A>(a)...));
}

struct Field {
  std::uint32_t offset = 0;
  std::uint8_t type = 0;
};

std::size_t type_size(std::uint8_t t) {
  switch (t) {
    case PointField::INT8:
    case PointField::UINT8:
      return 1;
    case PointField::INT16:
    case PointField::UINT16:
      return 2;
    case PointField::INT32:
    case PointField::UINT32:
    case PointField::FLOAT32:
      return 4;
    case PointField::FLOAT64:
      return 8;
    default:
      return 0;
  }
}

std::optional<Field> find_field(const sensor_msgs::PointCloud2& msg, const std::string& name, const std::string& what) {
  for (const auto& f : msg.fields) {
    if (f.name != name) continue;
    const std::size_t size = type_size(f.datatype);
    require(size > 0, "{}: field '{}' has an unknown datatype {}", what, name, int(f.datatype));
    require(f.offset + size <= msg.point_step, "{}: field '{}' (offset {}) lies outside the point (step {})", what,
            name, f.offset, msg.point_step);
    return Field{f.offset, f.datatype};
  }
  return std::nullopt;
}

// A real-valued field (x, y, z, normals): FLOAT32 or FLOAT64.
std::optional<Field> real_field(const sensor_msgs::PointCloud2& msg, const std::string& name, const std::string& what) {
  auto f = find_field(msg, name, what);
  if (f)
    require(f->type == PointField::FLOAT32 || f->type == PointField::FLOAT64,
            "{}: field '{}' must be FLOAT32 or FLOAT64 (datatype {})", what, name, int(f->type));
  return f;
}

double read_real(const std::uint8_t* p, const Field& f) {
  if (f.type == PointField::FLOAT64) {
    double d;
    std::memcpy(&d, p + f.offset, sizeof d);
    return d;
  }
  float v;
  std::memcpy(&v, p + f.offset, sizeof v);
  return static_cast<double>(v);
}

}  // namespace

Points from_cloud_msg(const sensor_msgs::PointCloud2& msg, const std::string& what) {
  require(!msg.is_bigendian, "{}: big-endian clouds are not supported", what);
  const std::size_t n = static_cast<std::size_t>(msg.width) * msg.height;
  require(msg.row_step >= static_cast<std::size_t>(msg.width) * msg.point_step,
          "{}: row_step {} is shorter than width {} x point_step {}", what, msg.row_step, msg.width, msg.point_step);
  require(msg.data.size() >= static_cast<std::size_t>(msg.row_step) * msg.height,
          "{}: {} bytes of data for {} rows of {} bytes", what, msg.data.size(), msg.height, msg.row_step);
  const auto x = real_field(msg, "x", what), y = real_field(msg, "y", what), z = real_field(msg, "z", what);
  require(x && y && z, "{}: the cloud has no x, y, z fields", what);
  const auto nx = real_field(msg, "normal_x", what), ny = real_field(msg, "normal_y", what),
             nz = real_field(msg, "normal_z", what);
  const bool normals = nx && ny && nz;
  auto rgb = find_field(msg, "rgb", what);
  if (!rgb) rgb = find_field(msg, "rgba", what);
  if (rgb)
    require(rgb->type == PointField::FLOAT32 || rgb->type == PointField::UINT32,
            "{}: field 'rgb' must be a packed FLOAT32 or UINT32 (datatype {})", what, int(rgb->type));
  Points out;
  out.xyz.reserve(n);
  bool normals_ok = normals;
  for (std::uint32_t row = 0; row < msg.height; ++row)
    for (std::uint32_t col = 0; col < msg.width; ++col) {
      const std::uint8_t* p = msg.data.data() + static_cast<std::size_t>(row) * msg.row_step +
                              static_cast<std::size_t>(col) * msg.point_step;
      const std::array<double, 3> q{read_real(p, *x), read_real(p, *y), read_real(p, *z)};
      if (!(std::isfinite(q[0]) && std::isfinite(q[1]) && std::isfinite(q[2]))) continue;
      out.xyz.push_back(q);
      if (normals_ok) {
        const std::array<double, 3> m{read_real(p, *nx), read_real(p, *ny), read_real(p, *nz)};
        if (std::isfinite(m[0]) && std::isfinite(m[1]) && std::isfinite(m[2]))
          out.normals.push_back(m);
        else
          normals_ok = false;
      }
      if (rgb) {
        std::uint32_t packed;
        std::memcpy(&packed, p + rgb->offset, sizeof packed);
        out.rgb.push_back({static_cast<std::uint8_t>((packed >> 16) & 0xff),
                           static_cast<std::uint8_t>((packed >> 8) & 0xff), static_cast<std::uint8_t>(packed & 0xff)});
      }
    }
  if (!normals_ok) out.normals.clear();
  return out;
}

sensor_msgs::PointCloud2 to_cloud_msg(const Points& cloud, const std::string& frame_id, bool float64) {
  sensor_msgs::PointCloud2 msg;
  msg.header.frame_id = frame_id;
  msg.height = 1;
  msg.width = static_cast<std::uint32_t>(cloud.size());
  msg.is_bigendian = false;
  msg.is_dense = true;
  const std::uint8_t type = float64 ? PointField::FLOAT64 : PointField::FLOAT32;
  const std::uint32_t size = float64 ? 8 : 4;
  std::uint32_t offset = 0;
  auto add = [&](const std::string& name, std::uint8_t t, std::uint32_t s) {
    PointField f;
    f.name = name;
    f.offset = offset;
    f.datatype = t;
    f.count = 1;
    msg.fields.push_back(f);
    offset += s;
  };
  for (const char* name : {"x", "y", "z"}) add(name, type, size);
  if (!cloud.normals.empty())
    for (const char* name : {"normal_x", "normal_y", "normal_z"}) add(name, type, size);
  if (!cloud.rgb.empty()) add("rgb", PointField::FLOAT32, 4);
  const bool conf = cloud.confidence.size() == cloud.size() && cloud.size() > 0;
  if (conf) add("confidence", PointField::FLOAT32, 4);
  msg.point_step = offset;
  msg.row_step = msg.point_step * msg.width;
  msg.data.resize(static_cast<std::size_t>(msg.row_step));
  auto put = [&](std::uint8_t* p, double v) {
    if (float64) {
      std::memcpy(p, &v, 8);
    } else {
      const float f = static_cast<float>(v);
      std::memcpy(p, &f, 4);
    }
  };
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    std::uint8_t* p = msg.data.data() + i * msg.point_step;
    for (int k = 0; k < 3; ++k) put(p + k * size, cloud.xyz[i][k]);
    std::uint32_t at = 3 * size;
    if (!cloud.normals.empty()) {
      for (int k = 0; k < 3; ++k) put(p + at + k * size, cloud.normals[i][k]);
      at += 3 * size;
    }
    if (!cloud.rgb.empty()) {
      const auto& c = cloud.rgb[i];
      const std::uint32_t packed = (std::uint32_t(c[0]) << 16) | (std::uint32_t(c[1]) << 8) | std::uint32_t(c[2]);
      std::memcpy(p + at, &packed, 4);
      at += 4;
    }
    if (conf) std::memcpy(p + at, &cloud.confidence[i], 4);
  }
  return msg;
}

// A Rigid <-> a point-like (x, y, z) and a quaternion-like (x, y, z, w) message: Transform's
// translation / rotation and Pose's position / orientation are the same numbers.
template <class Point, class Quat>
Rigid rigid_of(const Point& t, const Quat& q) {
  return {{t.x, t.y, t.z}, {q.x, q.y, q.z, q.w}};
}

template <class Point, class Quat>
void put_rigid(const Rigid& r, Point& t, Quat& q) {
  t.x = r.t[0];
  t.y = r.t[1];
  t.z = r.t[2];
  q.x = r.q[0];
  q.y = r.q[1];
  q.z = r.q[2];
  q.w = r.q[3];
}

Rigid to_rigid(const geometry_msgs::Transform& t) { return rigid_of(t.translation, t.rotation); }
Rigid to_rigid(const geometry_msgs::Pose& p) { return rigid_of(p.position, p.orientation); }

geometry_msgs::Transform to_transform_msg(const Rigid& r) {
  geometry_msgs::Transform t;
  put_rigid(r, t.translation, t.rotation);
  return t;
}

geometry_msgs::Pose to_pose_msg(const Rigid& r) {
  geometry_msgs::Pose p;
  put_rigid(r, p.position, p.orientation);
  return p;
}

DepthImage from_depth_msg(const sensor_msgs::Image& image, const sensor_msgs::CameraInfo& info,
                          const std::string& what) {
  namespace enc = sensor_msgs::image_encodings;
  require(image.encoding == enc::TYPE_16UC1 || image.encoding == enc::TYPE_32FC1,
          "{}: encoding '{}' is not a depth image (REP 118: 16UC1 in millimetres or 32FC1 in metres)", what,
          image.encoding);
  require(!image.is_bigendian, "{}: big-endian images are not supported", what);
  require(info.width == image.width && info.height == image.height,
          "{}: the image is {} x {} but its camera_info is {} x {}", what, image.width, image.height, info.width,
          info.height);
  DepthImage out;
  out.width = static_cast<int>(image.width);
  out.height = static_cast<int>(image.height);
  out.fx = info.K[0];
  out.fy = info.K[4];
  out.cx = info.K[2];
  out.cy = info.K[5];
  require(out.width > 0 && out.height > 0, "{}: an empty image ({} x {})", what, out.width, out.height);
  require(std::isfinite(out.fx) && std::isfinite(out.fy) && out.fx > 0 && out.fy > 0 && std::isfinite(out.cx) &&
              std::isfinite(out.cy),
          "{}: camera_info's K has no positive focal length (fx {}, fy {})", what, out.fx, out.fy);
  const bool mm = image.encoding == enc::TYPE_16UC1;
  const std::size_t px = mm ? 2 : 4, row_bytes = px * image.width;
  require(image.step >= row_bytes && image.data.size() >= static_cast<std::size_t>(image.step) * image.height,
          "{}: {} bytes of data (step {}) for {} x {} pixels of {} bytes", what, image.data.size(), image.step,
          image.width, image.height, px);
  const std::size_t n = static_cast<std::size_t>(image.width) * image.height;
  if (mm) {
    out.millimetres.resize(n);
    for (std::uint32_t r = 0; r < image.height; ++r)
      std::memcpy(out.millimetres.data() + static_cast<std::size_t>(r) * image.width,
                  image.data.data() + std::size_t(r) * image.step, row_bytes);
    return out;
  }
  out.metres.resize(n);
  for (std::uint32_t r = 0; r < image.height; ++r)
    std::memcpy(out.metres.data() + static_cast<std::size_t>(r) * image.width,
                image.data.data() + std::size_t(r) * image.step, row_bytes);
  return out;
}

namespace {

std_msgs::ColorRGBA rgba(double r, double g, double b, double a = 1.0) {
  std_msgs::ColorRGBA c;
  c.r = static_cast<float>(r);
  c.g = static_cast<float>(g);
  c.b = static_cast<float>(b);
  c.a = static_cast<float>(a);
  return c;
}

geometry_msgs::Point point_msg(const std::array<double, 3>& p) {
  geometry_msgs::Point m;
  m.x = p[0];
  m.y = p[1];
  m.z = p[2];
  return m;
}

visualization_msgs::Marker marker(const std::string& frame_id, const std::string& ns, int id, int type) {
  visualization_msgs::Marker m;
  m.header.frame_id = frame_id;
  m.ns = ns;
  m.id = id;
  m.type = type;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  return m;
}

}  // namespace

visualization_msgs::MarkerArray to_markers(const Points& model, const std::vector<Rigid>& views,
                                           const Core::Frustum& frustum, const std::string& frame_id,
                                           const std::vector<Region>& regions, std::size_t max_points) {
  using visualization_msgs::Marker;
  visualization_msgs::MarkerArray out;
  Marker clear;
  clear.header.frame_id = frame_id;
  clear.action = Marker::DELETEALL;
  out.markers.push_back(clear);
  const double d = frustum.depth;
  if (model.size() > 0) {
    Marker m = marker(frame_id, "model", 0, Marker::POINTS);
    m.scale.x = m.scale.y = 0.004 * d;
    const std::size_t stride =
        std::max<std::size_t>(1, (model.size() + max_points - 1) / std::max<std::size_t>(1, max_points));
    const bool conf = model.confidence.size() == model.size();
    for (std::size_t i = 0; i < model.size(); i += stride) {
      m.points.push_back(point_msg(model.xyz[i]));
      const double f = conf ? std::clamp(static_cast<double>(model.confidence[i]), 0.0, 1.0) : -1.0;
      m.colors.push_back(f < 0 ? rgba(0.6, 0.6, 0.6) : rgba(1.0 - f, f, 0.0));
    }
    out.markers.push_back(m);
  }
  Marker path = marker(frame_id, "path", 0, Marker::LINE_STRIP);
  path.scale.x = 0.005 * d;
  path.color = rgba(1.0, 1.0, 1.0, 0.8);
  for (std::size_t k = 0; k < views.size(); ++k) {
    // The frustum in the view's optical frame (z forward, x right, y down): the apex and the
    // corners of the image at d_o.
    Points f;
    f.xyz = {{0.0, 0.0, 0.0},
             {-frustum.tan_half_x * d, -frustum.tan_half_y * d, d},
             {frustum.tan_half_x * d, -frustum.tan_half_y * d, d},
             {frustum.tan_half_x * d, frustum.tan_half_y * d, d},
             {-frustum.tan_half_x * d, frustum.tan_half_y * d, d}};
    const Points w = transformed(f, views[k]);
    Marker m = marker(frame_id, "views", static_cast<int>(k), Marker::LINE_LIST);
    m.scale.x = 0.005 * d;
    m.color = k == 0 ? rgba(1.0, 0.9, 0.0) : rgba(0.0, 0.8, 1.0);
    for (int c = 1; c <= 4; ++c) {
      m.points.push_back(point_msg(w.xyz[0]));  // apex to corner
      m.points.push_back(point_msg(w.xyz[static_cast<std::size_t>(c)]));
      m.points.push_back(point_msg(w.xyz[static_cast<std::size_t>(c)]));  // the image's edge
      m.points.push_back(point_msg(w.xyz[static_cast<std::size_t>(c % 4 + 1)]));
    }
    out.markers.push_back(m);
    path.points.push_back(point_msg(w.xyz[0]));
  }
  if (path.points.size() >= 2) out.markers.push_back(path);
  for (std::size_t k = 0; k < regions.size(); ++k) {
    const Region& r = regions[k];
    Marker m = marker(frame_id, "regions", static_cast<int>(k), Marker::SPHERE);
    m.pose.position = point_msg(r.centroid);
    m.scale.x = m.scale.y = m.scale.z = std::max(2.0 * r.radius, 0.01 * d);
    m.color = r.reason == "not_scanned"   ? rgba(1.0, 0.0, 0.0, 0.35)
              : r.reason == "improving"   ? rgba(1.0, 0.55, 0.0, 0.35)
              : r.reason == "unreachable" ? rgba(0.5, 0.5, 0.5, 0.35)
                                          : rgba(0.6, 0.0, 0.8, 0.35);
    out.markers.push_back(m);
    Marker t = marker(frame_id, "region_labels", static_cast<int>(k), Marker::TEXT_VIEW_FACING);
    t.pose.position = point_msg(r.centroid);
    t.pose.position.z += std::max(r.radius, 0.01 * d);
    t.scale.z = 0.03 * d;
    t.color = rgba(1.0, 1.0, 1.0);
    t.text = fmt::format("{} {:.1f} %", r.reason, 100.0 * r.share);
    out.markers.push_back(t);
  }
  return out;
}

}  // namespace autoscan_ros
