#include "core/file_io.h"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"
#include "core/limits.h"

namespace lp {

std::string read_text_file(const std::string& path, const std::string& what, size_t max_bytes) {
  if (max_bytes == 0) max_bytes = size_t(limits().max_text_file_bytes);
  auto cannot = [&](int err) {
    return InputError(fmt::format("{}: cannot open{}{}: {}", path, what.empty() ? "" : " ", what, std::strerror(err)));
  };
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw cannot(errno);
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw cannot(errno);
  if (S_ISDIR(st.st_mode)) throw cannot(EISDIR);
  std::string bytes;
  char buf[65536];
  while (true) {
    const ssize_t got = ::read(fd, buf, sizeof buf);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) throw cannot(errno);
    if (got == 0) break;
    if (bytes.size() + size_t(got) > max_bytes) throw InputError(fmt::format("{}: larger than {} bytes", path, max_bytes));
    bytes.append(buf, size_t(got));
  }
  return bytes;
}

std::string lower_extension(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return {};
  std::string ext = path.substr(dot);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

bool is_radiance_file(const std::string& path) {
  const std::string e = lower_extension(path);
  return e == ".exr" || e == ".hdr" || e == ".pic" || e == ".rgbe" || e == ".pfm";
}

bool is_camera_image_file(const std::string& path) {
  const std::string e = lower_extension(path);
  return e == ".png" || e == ".jpg" || e == ".jpeg" || e == ".tif" || e == ".tiff";
}

}  // namespace lp
