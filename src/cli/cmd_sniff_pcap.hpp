#pragma once
// `lec sniff --pcap FILE`: the frames (queries and replies; noise is left
// out) as a classic pcap file of link type 147 (DLT_USER0), one packet per
// RTU frame with its wall-clock time. tshark decodes it as Modbus RTU when
// told that user DLT 0 carries "mbrtu" (docs/sniff.md has the command).

#include <chrono>
#include <cstdio>
#include <span>
#include <string>

namespace lec6::cli {

inline constexpr uint32_t kPcapLinkTypeUser0 = 147;

class PcapWriter {
 public:
  // Creates (truncates) `path` and writes the file header; CommandFailed naming the path on error.
  explicit PcapWriter(const std::string& path);
  ~PcapWriter();
  PcapWriter(const PcapWriter&) = delete;
  PcapWriter& operator=(const PcapWriter&) = delete;

  void write(std::span<const uint8_t> frame, std::chrono::system_clock::time_point at);
  // Flushes and closes; CommandFailed naming the path if anything could not be written.
  void close();

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
  bool failed_ = false;
};

}  // namespace lec6::cli
