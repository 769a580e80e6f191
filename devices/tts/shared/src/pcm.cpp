#include "urs/audio/pcm.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace urs::audio {

namespace {

constexpr double kPi = 3.14159265358979323846;
// Zero crossings of the sinc kept on each side of the centre: the transition band narrows and
// stop-band attenuation rises with it; 16 keeps aliases of speech below the 16-bit noise floor
// for a few dozen multiply-adds per output sample.
constexpr double kZeroCrossings = 16.0;
// Cut-off as a fraction of the lower Nyquist frequency, leaving room for the transition band.
constexpr double kCutoffFraction = 0.95;

void put_u16(std::string& out, uint16_t v) {
  out.push_back(static_cast<char>(v & 0xff));
  out.push_back(static_cast<char>(v >> 8));
}

void put_u32(std::string& out, uint32_t v) {
  for (int shift = 0; shift < 32; shift += 8) out.push_back(static_cast<char>((v >> shift) & 0xff));
}

uint16_t get_u16(const std::string& in, std::size_t at) {
  return static_cast<uint16_t>(static_cast<uint8_t>(in[at]) | static_cast<uint8_t>(in[at + 1]) << 8);
}

uint32_t get_u32(const std::string& in, std::size_t at) {
  return static_cast<uint32_t>(get_u16(in, at)) | static_cast<uint32_t>(get_u16(in, at + 2)) << 16;
}

int16_t clamp_sample(double v) {
  const double r = std::round(v);
  if (r > std::numeric_limits<int16_t>::max()) return std::numeric_limits<int16_t>::max();
  if (r < std::numeric_limits<int16_t>::min()) return std::numeric_limits<int16_t>::min();
  return static_cast<int16_t>(r);
}

}  // namespace

double Pcm::duration() const {
  if (sample_rate == 0 || channels == 0) return 0.0;
  return static_cast<double>(samples.size() / channels) / sample_rate;
}

std::string encode_wav(const Pcm& pcm) {
  const uint32_t data_bytes = static_cast<uint32_t>(pcm.samples.size() * 2);
  const uint16_t block_align = static_cast<uint16_t>(pcm.channels * 2);
  std::string out;
  out.reserve(44 + data_bytes);
  out += "RIFF";
  put_u32(out, 36 + data_bytes);
  out += "WAVEfmt ";
  put_u32(out, 16);
  put_u16(out, 1);  // integer PCM
  put_u16(out, pcm.channels);
  put_u32(out, pcm.sample_rate);
  put_u32(out, pcm.sample_rate * block_align);
  put_u16(out, block_align);
  put_u16(out, 16);
  out += "data";
  put_u32(out, data_bytes);
  for (int16_t s : pcm.samples) put_u16(out, static_cast<uint16_t>(s));
  return out;
}

Pcm decode_wav(const std::string& bytes) {
  if (bytes.size() < 12 || bytes.compare(0, 4, "RIFF") != 0 || bytes.compare(8, 4, "WAVE") != 0) {
    throw FormatError("not a RIFF/WAVE file (it must start with 'RIFF' and have form type 'WAVE')");
  }
  Pcm pcm;
  bool have_format = false;
  std::size_t at = 12;
  while (at + 8 <= bytes.size()) {
    const std::string id = bytes.substr(at, 4);
    // Writers that stream set the size to its maximum; what is present is what counts.
    const std::size_t size = std::min<std::size_t>(get_u32(bytes, at + 4), bytes.size() - at - 8);
    const std::size_t body = at + 8;
    if (id == "fmt ") {
      if (size < 16) throw FormatError("the 'fmt ' chunk is shorter than 16 bytes");
      uint16_t format = get_u16(bytes, body);
      if (format == 0xFFFE && size >= 26) format = get_u16(bytes, body + 24);  // EXTENSIBLE sub-format
      pcm.channels = get_u16(bytes, body + 2);
      pcm.sample_rate = get_u32(bytes, body + 4);
      const uint16_t bits = get_u16(bytes, body + 14);
      if (format != 1) {
        throw FormatError("WAV format tag " + std::to_string(format) + " is not supported (only integer PCM, tag 1)");
      }
      if (bits != 16) {
        throw FormatError(std::to_string(bits) + "-bit samples are not supported (only 16-bit)");
      }
      if (pcm.channels < 1 || pcm.channels > 2) {
        throw FormatError(std::to_string(pcm.channels) + " channels are not supported (1 or 2)");
      }
      if (pcm.sample_rate < 8000 || pcm.sample_rate > 96000) {
        throw FormatError("sample rate " + std::to_string(pcm.sample_rate) + " Hz is outside 8000..96000");
      }
      have_format = true;
    } else if (id == "data") {
      if (!have_format) throw FormatError("the 'data' chunk comes before the 'fmt ' chunk");
      pcm.samples = samples_from_bytes(bytes.substr(body, size - size % 2));
      return pcm;
    }
    at = body + size + size % 2;  // chunks are padded to an even length
  }
  throw FormatError(have_format ? "no 'data' chunk" : "no 'fmt ' chunk");
}

std::vector<int16_t> samples_from_bytes(const std::string& bytes) {
  if (bytes.size() % 2 != 0) {
    throw FormatError("an odd number of bytes (" + std::to_string(bytes.size()) + ") cannot hold 16-bit samples");
  }
  std::vector<int16_t> samples(bytes.size() / 2);
  for (std::size_t i = 0; i < samples.size(); ++i) samples[i] = static_cast<int16_t>(get_u16(bytes, 2 * i));
  return samples;
}

std::vector<int16_t> downmix(const std::vector<int16_t>& interleaved, uint16_t channels) {
  if (channels <= 1) return interleaved;
  std::vector<int16_t> mono(interleaved.size() / channels);
  for (std::size_t f = 0; f < mono.size(); ++f) {
    int sum = 0;
    for (uint16_t c = 0; c < channels; ++c) sum += interleaved[f * channels + c];
    mono[f] = static_cast<int16_t>(sum / channels);
  }
  return mono;
}

std::vector<int16_t> resample(const std::vector<int16_t>& mono, uint32_t from_rate, uint32_t to_rate) {
  if (from_rate == to_rate || mono.empty()) return mono;
  const double step = static_cast<double>(from_rate) / to_rate;                            // input samples per output
  const double cutoff = kCutoffFraction * 0.5 * std::min(from_rate, to_rate) / from_rate;  // cycles/input sample
  const double half_width = kZeroCrossings / (2.0 * cutoff);                               // input samples
  const std::size_t out_count = static_cast<std::size_t>(mono.size() / step);
  std::vector<int16_t> out(out_count);
  const long last = static_cast<long>(mono.size()) - 1;
  for (std::size_t n = 0; n < out_count; ++n) {
    const double t = n * step;
    const long first = static_cast<long>(std::ceil(t - half_width));
    const long end = static_cast<long>(std::floor(t + half_width));
    double acc = 0.0;
    double weights = 0.0;
    for (long k = first; k <= end; ++k) {
      const double x = k - t;
      const double arg = 2.0 * cutoff * x;
      const double sinc = arg == 0.0 ? 1.0 : std::sin(kPi * arg) / (kPi * arg);
      const double u = x / half_width;
      const double window = 0.42 + 0.5 * std::cos(kPi * u) + 0.08 * std::cos(2.0 * kPi * u);
      const double w = sinc * window;
      weights += w;  // over the whole kernel, so that the edges fade in rather than being boosted
      if (k >= 0 && k <= last) acc += w * mono[static_cast<std::size_t>(k)];
    }
    out[n] = clamp_sample(acc / weights);
  }
  return out;
}

std::vector<int16_t> to_mono(const Pcm& pcm, uint32_t rate) {
  return resample(downmix(pcm.samples, pcm.channels), pcm.sample_rate, rate);
}

}  // namespace urs::audio
