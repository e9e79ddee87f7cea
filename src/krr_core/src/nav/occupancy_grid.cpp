#include "krr_core/nav/occupancy_grid.h"

#include <png.h>
#include <yaml-cpp/yaml.h>

#include <cctype>
#include <cmath>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <limits>
#include <sstream>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/limits.h"
#include "krr_core/common/yaml_section.h"

namespace krr {
namespace nav {

Point2 OccupancyGrid::mapToWorld(double u, double v) const {
  const double lx = u * resolution;
  const double ly = v * resolution;
  const double c = std::cos(origin_yaw);
  const double s = std::sin(origin_yaw);
  return Point2{origin_x + c * lx - s * ly, origin_y + s * lx + c * ly};
}

void OccupancyGrid::worldToMap(const Point2& p, double* u, double* v) const {
  const double dx = p.x - origin_x;
  const double dy = p.y - origin_y;
  const double c = std::cos(origin_yaw);
  const double s = std::sin(origin_yaw);
  *u = (c * dx + s * dy) / resolution;
  *v = (-s * dx + c * dy) / resolution;
}

bool OccupancyGrid::worldToCell(const Point2& p, int* col, int* row) const {
  double u = 0.0;
  double v = 0.0;
  worldToMap(p, &u, &v);
  if (!(u >= 0.0 && v >= 0.0 && u < width && v < height)) return false;
  *col = static_cast<int>(u);
  *row = static_cast<int>(v);
  return true;
}

namespace {

/// Reads PGM header tokens, skipping whitespace and '#' comments.
class PgmHeaderReader {
 public:
  PgmHeaderReader(const std::string& bytes, const std::string& name) : b_(bytes), name_(name) {}

  long readInt(const char* what) {
    skipSpaceAndComments();
    if (pos_ >= b_.size()) throw MapError(name_ + ": truncated PGM header (missing " + what + ")");
    if (!std::isdigit(static_cast<unsigned char>(b_[pos_]))) {
      throw MapError(name_ + ": bad PGM header: " + what + " is not a number near byte " +
                     std::to_string(pos_));
    }
    long v = 0;
    while (pos_ < b_.size() && std::isdigit(static_cast<unsigned char>(b_[pos_]))) {
      v = v * 10 + (b_[pos_] - '0');
      if (v > 100000000L) throw MapError(name_ + ": bad PGM header: " + what + " is too large");
      ++pos_;
    }
    return v;
  }

  void skipSpaceAndComments() {
    while (pos_ < b_.size()) {
      char c = b_[pos_];
      if (c == '#') {
        while (pos_ < b_.size() && b_[pos_] != '\n') ++pos_;
      } else if (std::isspace(static_cast<unsigned char>(c))) {
        ++pos_;
      } else {
        break;
      }
    }
  }

  size_t pos_ = 2;  // after the magic

 private:
  const std::string& b_;
  const std::string& name_;
};

}  // namespace

MapImage parsePgm(const std::string& bytes, const std::string& name) {
  if (bytes.size() < 2 || bytes[0] != 'P' || (bytes[1] != '5' && bytes[1] != '2')) {
    std::string magic = bytes.substr(0, std::min<size_t>(2, bytes.size()));
    for (char& c : magic) {
      if (!std::isprint(static_cast<unsigned char>(c))) c = '?';
    }
    throw MapError(name + ": bad magic '" + magic + "': expected a PGM image (P5 or P2)");
  }
  const bool binary = bytes[1] == '5';
  PgmHeaderReader rd(bytes, name);
  MapImage img;
  long w = rd.readInt("width");
  long h = rd.readInt("height");
  long maxval = rd.readInt("maxval");
  if (w <= 0 || h <= 0) {
    throw MapError(name + ": bad PGM size " + std::to_string(w) + "x" + std::to_string(h));
  }
  if (w * h > 100000000L) throw MapError(name + ": PGM image too large");
  if (maxval <= 0 || maxval > 65535) {
    throw MapError(name + ": bad PGM maxval " + std::to_string(maxval) + " (must be 1..65535)");
  }
  img.width = static_cast<int>(w);
  img.height = static_cast<int>(h);
  img.maxval = static_cast<int>(maxval);
  const size_t n = static_cast<size_t>(w) * static_cast<size_t>(h);
  // The header alone decides the allocation: check it against the budget first. Loading keeps
  // the 16-bit pixels and the 8-bit grid made from them.
  const size_t need = saturatingMul(n, sizeof(std::uint16_t) + sizeof(std::int8_t));
  const size_t budget = memoryBudget();
  if (need > budget) {
    throw MapError(name + ": PGM image " + std::to_string(w) + "x" + std::to_string(h) +
                   " needs about " + formatBytes(need) + ", above the memory budget of " +
                   formatBytes(budget) + " (KRR_MEMORY_BUDGET_MIB)");
  }
  size_t pos = rd.pos_;
  // A P2 value takes at least two bytes (digit and separator): a header promising more pixels
  // than the file can hold is truncated, whatever the budget, so nothing is allocated for it.
  if (!binary && (bytes.size() - pos + 1) / 2 < n) {
    throw MapError(name + ": truncated PGM data: " + std::to_string(w) + "x" + std::to_string(h) +
                   " values cannot fit in the " + std::to_string(bytes.size() - pos) +
                   " bytes after the header");
  }
  if (binary) {
    const size_t bpp = maxval > 255 ? 2 : 1;
    if (pos < bytes.size() && bytes.size() - pos - 1 < n * bpp) {
      throw MapError(name + ": truncated PGM data: expected " + std::to_string(n * bpp) +
                     " bytes, found " + std::to_string(bytes.size() - pos - 1));
    }
  }
  img.pixels.resize(n);
  if (binary) {
    // Exactly one whitespace byte separates the header from the raster.
    if (pos >= bytes.size() || !std::isspace(static_cast<unsigned char>(bytes[pos]))) {
      throw MapError(name + ": truncated PGM data (no raster after header)");
    }
    ++pos;
    const size_t bpp = maxval > 255 ? 2 : 1;
    if (bytes.size() - pos < n * bpp) {
      throw MapError(name + ": truncated PGM data: expected " + std::to_string(n * bpp) +
                     " bytes, found " + std::to_string(bytes.size() - pos));
    }
    const unsigned char* p = reinterpret_cast<const unsigned char*>(bytes.data()) + pos;
    for (size_t i = 0; i < n; ++i) {
      unsigned v = bpp == 1 ? p[i] : (static_cast<unsigned>(p[2 * i]) << 8) | p[2 * i + 1];
      if (v > static_cast<unsigned>(maxval)) {
        throw MapError(name + ": PGM pixel " + std::to_string(i) + " value " + std::to_string(v) +
                       " exceeds maxval " + std::to_string(maxval));
      }
      img.pixels[i] = static_cast<std::uint16_t>(v);
    }
  } else {
    rd.pos_ = pos;
    for (size_t i = 0; i < n; ++i) {
      rd.skipSpaceAndComments();
      if (rd.pos_ >= bytes.size()) {
        throw MapError(name + ": truncated PGM data: expected " + std::to_string(n) +
                       " values, found " + std::to_string(i));
      }
      long v = rd.readInt("pixel value");
      if (v > maxval) {
        throw MapError(name + ": PGM pixel " + std::to_string(i) + " value " + std::to_string(v) +
                       " exceeds maxval " + std::to_string(maxval));
      }
      img.pixels[i] = static_cast<std::uint16_t>(v);
    }
  }
  return img;
}

namespace {

constexpr std::size_t kPngSignatureSize = 8;

/**
 * @brief What libpng reads from, and where its error message lands.
 *
 * Plain data only: libpng reports errors by longjmp, which must not skip a C++ destructor, so
 * the functions that call into libpng (pngReadHeader, pngReadPixels) hold nothing but this.
 */
struct PngSource {
  const unsigned char* data;
  std::size_t size;
  std::size_t pos;
  char message[256];
};

void pngReadData(png_structp png, png_bytep out, png_size_t n) {
  PngSource* src = static_cast<PngSource*>(png_get_io_ptr(png));
  if (n > src->size - src->pos) png_error(png, "truncated PNG data (file ends early)");
  std::memcpy(out, src->data + src->pos, n);
  src->pos += n;
}

[[noreturn]] void pngOnError(png_structp png, png_const_charp message) {
  PngSource* src = static_cast<PngSource*>(png_get_error_ptr(png));
  std::snprintf(src->message, sizeof(src->message), "%s", message);
  png_longjmp(png, 1);
}

/// @brief Warnings (a bad CRC in an ancillary chunk, say) do not change the pixels: stay quiet.
void pngOnWarning(png_structp, png_const_charp) {}

/// @brief Owns the libpng read structures, so that every exit path frees them.
struct PngReader {
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~PngReader() {
    if (png != nullptr) png_destroy_read_struct(&png, &info, nullptr);
  }
};

/// @brief Read up to the image header (no pixel memory yet); false on a libpng error.
bool pngReadHeader(png_structp png, png_infop info) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_info(png, info);
  return true;
}

/**
 * @brief Set SDL_image's transformations and decode into caller-owned rows; false on error.
 *
 * 16 bit -> high byte (png_set_strip_16), grey 1/2/4 bit -> 0..255, grey + alpha -> RGBA,
 * palette -> RGB (RGBA with a tRNS chunk). The decoded layout must be `channels` bytes a pixel.
 */
bool pngReadPixels(png_structp png, png_infop info, int channels, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  const int color_type = png_get_color_type(png, info);
  if (png_get_bit_depth(png, info) == 16) png_set_strip_16(png);
  if (color_type == PNG_COLOR_TYPE_PALETTE) {
    png_set_palette_to_rgb(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
  } else if (color_type == PNG_COLOR_TYPE_GRAY) {
    png_set_expand_gray_1_2_4_to_8(png);
  } else if (color_type == PNG_COLOR_TYPE_GRAY_ALPHA) {
    png_set_gray_to_rgb(png);
  }
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  if (png_get_channels(png, info) != static_cast<png_byte>(channels) ||
      png_get_bit_depth(png, info) != 8 ||
      png_get_rowbytes(png, info) !=
          static_cast<png_size_t>(png_get_image_width(png, info)) * channels) {
    png_error(png, "unexpected pixel layout after decoding");
  }
  png_read_image(png, rows);
  png_read_end(png, nullptr);  // the CRCs up to IEND: a truncated file is an error
  return true;
}

}  // namespace

MapImage parsePng(const std::string& bytes, const std::string& name) {
  const unsigned char* data = reinterpret_cast<const unsigned char*>(bytes.data());
  if (bytes.size() < kPngSignatureSize ||
      png_sig_cmp(data, 0, kPngSignatureSize) != 0) {
    throw MapError(name + ": bad PNG signature: not a PNG image");
  }
  PngSource src{data, bytes.size(), 0, {0}};
  PngReader reader;
  reader.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &src, pngOnError, pngOnWarning);
  if (reader.png == nullptr) throw MapError(name + ": cannot start the PNG decoder");
  reader.info = png_create_info_struct(reader.png);
  if (reader.info == nullptr) throw MapError(name + ": cannot start the PNG decoder");
  png_set_read_fn(reader.png, &src, pngReadData);
  if (!pngReadHeader(reader.png, reader.info)) {
    throw MapError(name + ": bad PNG header: " + src.message);
  }
  const png_uint_32 w = png_get_image_width(reader.png, reader.info);
  const png_uint_32 h = png_get_image_height(reader.png, reader.info);
  const int color_type = png_get_color_type(reader.png, reader.info);
  int channels = 3;
  if (color_type == PNG_COLOR_TYPE_GRAY) {
    channels = 1;
  } else if (color_type == PNG_COLOR_TYPE_GRAY_ALPHA || color_type == PNG_COLOR_TYPE_RGB_ALPHA ||
             (color_type == PNG_COLOR_TYPE_PALETTE &&
              png_get_valid(reader.png, reader.info, PNG_INFO_tRNS))) {
    channels = 4;
  }
  const std::string size = std::to_string(w) + "x" + std::to_string(h);
  if (static_cast<std::uint64_t>(w) * h > 100000000ULL) {
    throw MapError(name + ": PNG image " + size + " too large");
  }
  // The header alone decides the allocation: check it against the budget first. Loading keeps
  // the decoded bytes, the 16-bit samples made from them and the 8-bit grid.
  const std::size_t n = static_cast<std::size_t>(w) * h;
  const std::size_t need = saturatingMul(
      n, static_cast<std::size_t>(channels) * (1 + sizeof(std::uint16_t)) + sizeof(std::int8_t));
  const std::size_t budget = memoryBudget();
  if (need > budget) {
    throw MapError(name + ": PNG image " + size + " needs about " + formatBytes(need) +
                   ", above the memory budget of " + formatBytes(budget) +
                   " (KRR_MEMORY_BUDGET_MIB)");
  }
  std::vector<png_byte> decoded(n * channels);
  std::vector<png_bytep> rows(h);
  for (png_uint_32 r = 0; r < h; ++r) rows[r] = decoded.data() + std::size_t(r) * w * channels;
  if (!pngReadPixels(reader.png, reader.info, channels, rows.data())) {
    throw MapError(name + ": corrupt PNG data: " + src.message);
  }
  MapImage img;
  img.width = static_cast<int>(w);
  img.height = static_cast<int>(h);
  img.channels = channels;
  img.has_alpha = channels == 4;
  img.maxval = 255;
  img.pixels.assign(decoded.begin(), decoded.end());
  return img;
}

MapImage parseImage(const std::string& bytes, const std::string& name) {
  if (bytes.size() >= kPngSignatureSize && static_cast<unsigned char>(bytes[0]) == 0x89 &&
      bytes.compare(1, 3, "PNG") == 0) {
    return parsePng(bytes, name);
  }
  if (bytes.size() >= 2 && bytes[0] == 'P' && (bytes[1] == '5' || bytes[1] == '2')) {
    return parsePgm(bytes, name);
  }
  std::string magic = bytes.substr(0, std::min<size_t>(2, bytes.size()));
  for (char& c : magic) {
    if (!std::isprint(static_cast<unsigned char>(c))) c = '?';
  }
  throw MapError(name + ": bad magic '" + magic +
                 "': expected a PGM (P5 or P2) or PNG image, as map_server reads");
}

MapImage readImage(const std::string& path) {
  std::string bytes;
  try {
    bytes = readFile(path);
  } catch (const IoError& e) {
    throw MapError(std::string("cannot read image ") + e.what());  // e names the file
  }
  return parseImage(bytes, path);
}

MapMetadata loadMapMetadata(const std::string& yaml_path) {
  const YAML::Node root = loadYamlMapFile(yaml_path, "map YAML");
  if (!root.IsMap()) throw MapError(yaml_path + ": broken YAML: top level is not a mapping");
  // map_server's semantics: the keys it does not read are ignored; errors are MapError.
  const YamlSection s(root, yaml_path, "", {}, YamlSection::Format::kMapServer);
  MapMetadata m;
  m.image = s.requiredString("image");
  m.resolution = s.requiredNumber("resolution", 0.0, std::numeric_limits<double>::max(),
                                  YamlSection::kLowerOpen);
  const std::vector<double> origin = s.requiredNumbers("origin", 3, "[x, y, yaw]");
  for (size_t i = 0; i < 3; ++i) m.origin[i] = origin[i];
  m.occupied_thresh = s.requiredNumber("occupied_thresh", 0.0, 1.0);
  m.free_thresh = s.requiredNumber("free_thresh", 0.0, 1.0);
  if (m.occupied_thresh <= m.free_thresh) {
    throw MapError(yaml_path + ": field 'occupied_thresh': value " +
                   std::to_string(m.occupied_thresh) + " must be > free_thresh " +
                   std::to_string(m.free_thresh));
  }
  // map_server writes negate as 0/1; accept booleans too.
  if (s.has("negate") && !s.get("negate").IsScalar())
    s.fail("negate", "must be 0, 1, true or false");
  const std::string negate = s.requiredString("negate");
  if (negate == "0" || negate == "1") {
    m.negate = negate == "1";
  } else {
    try {
      m.negate = s.get("negate").as<bool>();
    } catch (const YAML::Exception&) {
      s.fail("negate", "must be 0, 1, true or false");
    }
  }
  const std::string mode = s.string("mode", "trinary");
  if (mode == "trinary") {
    m.mode = MapMode::kTrinary;
  } else if (mode == "scale") {
    m.mode = MapMode::kScale;
  } else if (mode == "raw") {
    m.mode = MapMode::kRaw;
  } else {
    throw MapError(yaml_path + ": field 'mode': unknown value '" + mode +
                   "' (expected trinary, scale or raw)");
  }
  return m;
}

OccupancyGrid imageToGrid(const MapImage& image, const MapMetadata& meta) {
  const int ch = image.channels;
  if ((ch != 1 && ch != 3 && ch != 4) || (image.has_alpha && ch != 4) || image.maxval <= 0 ||
      image.width < 0 || image.height < 0 ||
      image.pixels.size() != static_cast<size_t>(image.width) * image.height * ch) {
    throw MapError("map image: inconsistent size " + std::to_string(image.width) + "x" +
                   std::to_string(image.height) + "x" + std::to_string(ch) + " for " +
                   std::to_string(image.pixels.size()) + " samples");
  }
  OccupancyGrid g;
  g.width = image.width;
  g.height = image.height;
  g.resolution = meta.resolution;
  g.origin_x = meta.origin[0];
  g.origin_y = meta.origin[1];
  g.origin_yaw = meta.origin[2];
  g.data.assign(static_cast<size_t>(g.width) * static_cast<size_t>(g.height), kUnknown);
  // map_server averages alpha in with the colours in trinary mode only (kept for compatibility).
  const int avg_channels = (meta.mode == MapMode::kTrinary || !image.has_alpha) ? ch : ch - 1;
  const double maxval = image.maxval;
  auto sample = [&](const std::uint16_t* px, int c) {
    return image.maxval == 255 ? double(px[c]) : px[c] * 255.0 / maxval;
  };
  for (int j = 0; j < image.height; ++j) {
    const int row = image.height - 1 - j;  // image row 0 is the top of the map
    for (int i = 0; i < image.width; ++i) {
      const std::uint16_t* px = &image.pixels[(static_cast<size_t>(j) * image.width + i) * ch];
      double sum = 0.0;
      for (int c = 0; c < avg_channels; ++c) sum += sample(px, c);
      double v = sum / avg_channels;
      if (meta.negate) v = 255.0 - v;
      std::int8_t value;
      if (meta.mode == MapMode::kRaw) {
        // map_server stores the grey value itself, truncated to a byte and wrapped into the
        // int8 message field.
        value = static_cast<std::int8_t>(static_cast<std::uint8_t>(v));
      } else {
        const double occ = (255.0 - v) / 255.0;
        const bool transparent = image.has_alpha && sample(px, ch - 1) < 1.0;
        if (occ > meta.occupied_thresh) {
          value = kOccupied;
        } else if (occ < meta.free_thresh) {
          value = kFree;
        } else if (meta.mode == MapMode::kTrinary || transparent) {
          value = kUnknown;
        } else {
          const double ratio = (occ - meta.free_thresh) / (meta.occupied_thresh - meta.free_thresh);
          value = static_cast<std::int8_t>(1 + 98 * ratio);  // truncation, as map_server does
        }
      }
      g.data[static_cast<size_t>(g.index(i, row))] = value;
    }
  }
  return g;
}

OccupancyGrid loadMap(const std::string& yaml_path) {
  MapMetadata meta = loadMapMetadata(yaml_path);
  std::string image_path = meta.image;
  if (image_path[0] != '/') image_path = dirName(yaml_path) + "/" + image_path;
  MapImage img;
  try {
    img = readImage(image_path);
  } catch (const MapError& e) {
    // Name the YAML too: the image file may be something the YAML should not point at.
    throw MapError(yaml_path + ": field 'image': " + e.what());
  }
  return imageToGrid(img, meta);
}

std::string encodePgm(const OccupancyGrid& grid) {
  std::ostringstream out;
  out << "P5\n# CREATOR: krr_core nav " << grid.resolution << " m/pix\n"
      << grid.width << " " << grid.height << "\n255\n";
  std::string header = out.str();
  std::string data(static_cast<size_t>(grid.width) * static_cast<size_t>(grid.height), '\0');
  for (int j = 0; j < grid.height; ++j) {
    const int row = grid.height - 1 - j;
    for (int i = 0; i < grid.width; ++i) {
      const std::int8_t v = grid.data[static_cast<size_t>(grid.index(i, row))];
      unsigned char px = 205;  // unknown (map_saver convention)
      if (v == kFree) {
        px = 254;
      } else if (v == kOccupied) {
        px = 0;
      }
      data[static_cast<size_t>(j) * grid.width + i] = static_cast<char>(px);
    }
  }
  return header + data;
}

void saveMap(const OccupancyGrid& grid, const std::string& yaml_path,
             const std::string& image_name) {
  writeFileAtomic(dirName(yaml_path) + "/" + image_name, encodePgm(grid));
  std::ostringstream y;
  y.precision(10);
  y << "image: " << image_name << "\n"
    << "resolution: " << grid.resolution << "\n"
    << "origin: [" << grid.origin_x << ", " << grid.origin_y << ", " << grid.origin_yaw << "]\n"
    << "negate: 0\n"
    << "occupied_thresh: 0.65\n"
    << "free_thresh: 0.196\n"
    << "mode: trinary\n";
  writeFileAtomic(yaml_path, y.str());
}

}  // namespace nav
}  // namespace krr
