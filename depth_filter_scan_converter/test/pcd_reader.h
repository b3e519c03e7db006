// Minimal PCD v0.7 reader for tests and benchmarks (ascii is not needed; binary and
// binary_compressed are). Fills an interleaved buffer and the matching CloudLayout, so the
// data reaches the core through the same path as a PointCloud2.
#pragma once

#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "depth_filter_scan_converter/cloud_view.h"

namespace depth_filter_scan_converter
{
namespace test
{
struct PcdCloud
{
  CloudLayout layout;
  std::vector<std::uint8_t> data;
};

// LZF as written by PCL: a control byte below 32 starts a literal run of ctrl+1 bytes;
// otherwise a back reference of length (ctrl >> 5) + 2 (extended by one byte when 7).
inline std::vector<std::uint8_t> lzfDecompress(const std::uint8_t* in, std::size_t in_size, std::size_t out_size)
{
  std::vector<std::uint8_t> out(out_size);
  std::size_t ip = 0, op = 0;
  while (ip < in_size)
  {
    const unsigned ctrl = in[ip++];
    if (ctrl < 32)
    {
      const std::size_t len = ctrl + 1;
      if (ip + len > in_size || op + len > out_size)
        throw std::runtime_error("lzf: literal run overflows");
      std::memcpy(&out[op], &in[ip], len);
      ip += len;
      op += len;
    }
    else
    {
      std::size_t len = ctrl >> 5;
      if (ip >= in_size)
        throw std::runtime_error("lzf: truncated");
      if (len == 7)
        len += in[ip++];
      if (ip >= in_size)
        throw std::runtime_error("lzf: truncated");
      const std::size_t back = ((ctrl & 0x1f) << 8) + in[ip++] + 1;
      len += 2;
      if (back > op || op + len > out_size)
        throw std::runtime_error("lzf: bad back reference");
      for (std::size_t i = 0; i < len; ++i, ++op)
        out[op] = out[op - back];  // byte by byte: source and target may overlap
    }
  }
  if (op != out_size)
    throw std::runtime_error("lzf: wrong decompressed size");
  return out;
}

inline PcdCloud readPcd(const std::string& path)
{
  std::ifstream file(path, std::ios::binary);
  if (!file)
    throw std::runtime_error("cannot open " + path);
  std::vector<std::string> names;
  std::vector<std::uint32_t> sizes, counts;
  std::vector<char> types;
  PcdCloud cloud;
  std::string line, mode;
  while (std::getline(file, line))
  {
    std::istringstream ss(line);
    std::string key;
    ss >> key;
    if (key == "FIELDS")
      for (std::string v; ss >> v;)
        names.push_back(v);
    else if (key == "SIZE")
      for (std::uint32_t v; ss >> v;)
        sizes.push_back(v);
    else if (key == "TYPE")
      for (char v; ss >> v;)
        types.push_back(v);
    else if (key == "COUNT")
      for (std::uint32_t v; ss >> v;)
        counts.push_back(v);
    else if (key == "WIDTH")
      ss >> cloud.layout.width;
    else if (key == "HEIGHT")
      ss >> cloud.layout.height;
    else if (key == "DATA")
    {
      ss >> mode;
      break;
    }
  }
  if (counts.empty())
    counts.assign(names.size(), 1);
  if (names.size() != sizes.size() || names.size() != types.size() || names.size() != counts.size())
    throw std::runtime_error("inconsistent PCD header in " + path);

  std::uint32_t step = 0;
  for (std::size_t i = 0; i < names.size(); ++i)
  {
    FieldDescription f;
    f.name = names[i];
    f.offset = step;
    f.count = counts[i];
    const char t = types[i];
    const std::uint32_t s = sizes[i];
    f.datatype = t == 'F' ? (s == 8 ? 8 : 7) : t == 'U' ? (s == 1 ? 2 : s == 2 ? 4 : 6) : (s == 1 ? 1 : s == 2 ? 3 : 5);
    cloud.layout.fields.push_back(f);
    step += s * counts[i];
  }
  cloud.layout.point_step = step;
  cloud.layout.row_step = step * cloud.layout.width;
  const std::size_t points = static_cast<std::size_t>(cloud.layout.width) * cloud.layout.height;
  const std::size_t total = points * step;

  if (mode == "binary")
  {
    cloud.data.resize(total);
    file.read(reinterpret_cast<char*>(cloud.data.data()), static_cast<std::streamsize>(total));
  }
  else if (mode == "binary_compressed")
  {
    std::uint32_t sizes_header[2];
    file.read(reinterpret_cast<char*>(sizes_header), sizeof sizes_header);
    std::vector<std::uint8_t> packed(sizes_header[0]);
    file.read(reinterpret_cast<char*>(packed.data()), static_cast<std::streamsize>(packed.size()));
    if (sizes_header[1] != total)
      throw std::runtime_error("unexpected uncompressed size in " + path);
    // Compressed PCD stores each field for all points, one field after the other.
    const std::vector<std::uint8_t> planar = lzfDecompress(packed.data(), packed.size(), total);
    cloud.data.resize(total);
    std::size_t plane = 0;
    for (std::size_t i = 0; i < names.size(); ++i)
    {
      const std::size_t fs = static_cast<std::size_t>(sizes[i]) * counts[i];
      const std::size_t off = cloud.layout.fields[i].offset;
      for (std::size_t p = 0; p < points; ++p)
        std::memcpy(&cloud.data[p * step + off], &planar[plane + p * fs], fs);
      plane += fs * points;
    }
  }
  else
  {
    throw std::runtime_error("unsupported PCD DATA mode '" + mode + "' in " + path);
  }
  if (!file)
    throw std::runtime_error("truncated PCD file " + path);
  return cloud;
}

}  // namespace test
}  // namespace depth_filter_scan_converter
