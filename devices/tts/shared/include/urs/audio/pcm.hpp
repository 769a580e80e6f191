#pragma once
// 16-bit PCM audio as the speech devices exchange it: RIFF/WAVE files in and out, down-mixing
// to mono and sample-rate conversion. Everything works on memory; nothing here does I/O.

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace urs::audio {

// A WAV file or a PCM chunk that cannot be used; the text says what is wrong and what is allowed.
class FormatError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Pcm {
  uint32_t sample_rate = 0;      // Hz
  uint16_t channels = 0;         // samples are interleaved when > 1
  std::vector<int16_t> samples;  // frames * channels values
  double duration() const;       // s
};

// A complete RIFF/WAVE file (44-byte canonical header, PCM format 1, 16-bit little-endian).
std::string encode_wav(const Pcm& pcm);

// Reads a RIFF/WAVE file holding 16-bit integer PCM (format 1, or WAVE_FORMAT_EXTENSIBLE with
// the PCM sub-format) with 1 or 2 channels; skips unknown chunks. Throws FormatError otherwise.
Pcm decode_wav(const std::string& bytes);

// Little-endian 16-bit samples from raw bytes; FormatError if the byte count is odd.
std::vector<int16_t> samples_from_bytes(const std::string& bytes);

// Averages interleaved channels into one.
std::vector<int16_t> downmix(const std::vector<int16_t>& interleaved, uint16_t channels);

// Band-limited sample-rate conversion: every output sample is the input convolved with a
// Blackman-windowed sinc low-pass (cut-off just under the lower Nyquist frequency) evaluated at
// the output instant, so down-sampling does not alias and up-sampling does not image.
std::vector<int16_t> resample(const std::vector<int16_t>& mono, uint32_t from_rate, uint32_t to_rate);

// `pcm` as mono at `rate` (down-mixed and resampled as needed).
std::vector<int16_t> to_mono(const Pcm& pcm, uint32_t rate);

}  // namespace urs::audio
