#include "cli/cmd_sniff_pcap.hpp"

#include <cerrno>
#include <cstring>

#include "cli/app.hpp"

namespace lec6::cli {
namespace {

// pcap's headers are in the writer's byte order; the magic tells readers which.
template <typename T>
void put(std::FILE* f, T v, bool& failed) {
  if (std::fwrite(&v, sizeof v, 1, f) != 1) failed = true;
}

}  // namespace

PcapWriter::PcapWriter(const std::string& path) : path_(path) {
  file_ = std::fopen(path.c_str(), "wb");
  if (!file_)
    throw CommandFailed(kFailure, fmt::format("cannot create {}: {}", path, std::strerror(errno)));
  put<uint32_t>(file_, 0xA1B2C3D4, failed_);  // microsecond timestamps
  put<uint16_t>(file_, 2, failed_);
  put<uint16_t>(file_, 4, failed_);
  put<int32_t>(file_, 0, failed_);      // time zone: UTC
  put<uint32_t>(file_, 0, failed_);     // accuracy
  put<uint32_t>(file_, 65535, failed_);  // snapshot length
  put<uint32_t>(file_, kPcapLinkTypeUser0, failed_);
}

PcapWriter::~PcapWriter() {
  if (file_) std::fclose(file_);
}

void PcapWriter::write(std::span<const uint8_t> frame, std::chrono::system_clock::time_point at) {
  if (!file_) return;
  const auto us =
      std::chrono::duration_cast<std::chrono::microseconds>(at.time_since_epoch()).count();
  put<uint32_t>(file_, static_cast<uint32_t>(us / 1'000'000), failed_);
  put<uint32_t>(file_, static_cast<uint32_t>(us % 1'000'000), failed_);
  put<uint32_t>(file_, static_cast<uint32_t>(frame.size()), failed_);
  put<uint32_t>(file_, static_cast<uint32_t>(frame.size()), failed_);
  if (!frame.empty() && std::fwrite(frame.data(), frame.size(), 1, file_) != 1) failed_ = true;
}

void PcapWriter::close() {
  if (!file_) return;
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (failed_ || !closed)
    throw CommandFailed(kFailure, fmt::format("cannot write {}: {}", path_, std::strerror(errno)));
}

}  // namespace lec6::cli
