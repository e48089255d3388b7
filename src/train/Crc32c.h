#pragma once
// CRC-32C (Castagnoli, reflected polynomial 0x82F63B78), the checksum of
// TFRecord framing (TensorBoard event files) and of feature-store records.

#include <cstdint>
#include <string_view>

namespace vln::train {

/// CRC-32C of `data`, continuing from `crc` (0 to start). crc32c("123456789")
/// is 0xE3069283 (the standard check value). Uses the CPU's CRC32
/// instruction (SSE4.2) where there is one: the feature store checks every
/// record it reads, gigabytes per training epoch, and the table loop costs
/// a few percent of an update there.
uint32_t crc32c(std::string_view data, uint32_t crc = 0);

/// The same checksum computed a byte at a time from a table, on any CPU:
/// the reference the instruction path is tested against.
uint32_t crc32cPortable(std::string_view data, uint32_t crc = 0);

/// TFRecord's masked CRC: ((crc >> 15) | (crc << 17)) + 0xa282ead8, so that
/// a CRC of data that itself contains CRCs stays well distributed.
uint32_t maskCrc32c(uint32_t crc);

}  // namespace vln::train
