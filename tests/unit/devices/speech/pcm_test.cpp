#include "urs/audio/pcm.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace urs::audio {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::vector<int16_t> tone(double hz, uint32_t rate, double seconds, double amplitude) {
  std::vector<int16_t> out(static_cast<std::size_t>(rate * seconds));
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i] = static_cast<int16_t>(std::lround(amplitude * std::sin(2 * kPi * hz * i / rate)));
  }
  return out;
}

// Root mean square away from the edges, where the filter sees the zero padding.
double rms_middle(const std::vector<int16_t>& s) {
  double sum = 0;
  const std::size_t from = s.size() / 4, to = 3 * s.size() / 4;
  for (std::size_t i = from; i < to; ++i) sum += static_cast<double>(s[i]) * s[i];
  return std::sqrt(sum / static_cast<double>(to - from));
}

std::size_t rising_zero_crossings(const std::vector<int16_t>& s) {
  std::size_t n = 0;
  for (std::size_t i = 1; i < s.size(); ++i) n += (s[i - 1] < 0 && s[i] >= 0) ? 1 : 0;
  return n;
}

TEST(Wav, EncodeThenDecodeGivesTheSameAudio) {
  Pcm pcm{16000, 1, {0, 1, -1, 32767, -32768, 1234}};
  const std::string wav = encode_wav(pcm);
  ASSERT_EQ(wav.size(), 44u + 12u);
  EXPECT_EQ(wav.substr(0, 4), "RIFF");
  EXPECT_EQ(wav.substr(8, 8), "WAVEfmt ");
  EXPECT_EQ(wav.substr(36, 4), "data");
  const Pcm back = decode_wav(wav);
  EXPECT_EQ(back.sample_rate, 16000u);
  EXPECT_EQ(back.channels, 1u);
  EXPECT_EQ(back.samples, pcm.samples);
  EXPECT_DOUBLE_EQ(Pcm({16000, 2, std::vector<int16_t>(32000)}).duration(), 1.0);
}

TEST(Wav, SkipsUnknownChunksAndReadsStereo) {
  std::string wav = encode_wav(Pcm{44100, 2, {10, 20, -30, -50}});
  // A LIST chunk with an odd size (padded) between fmt and data, as some recorders write.
  wav.insert(36, std::string("LIST\x03\x00\x00\x00"
                             "abc\0",
                             12));
  const Pcm pcm = decode_wav(wav);
  EXPECT_EQ(pcm.sample_rate, 44100u);
  EXPECT_EQ(pcm.channels, 2u);
  EXPECT_EQ(pcm.samples, (std::vector<int16_t>{10, 20, -30, -50}));
  EXPECT_EQ(downmix(pcm.samples, 2), (std::vector<int16_t>{15, -40}));
}

TEST(Wav, RefusesWhatItCannotRead) {
  EXPECT_THROW(decode_wav("not a wave file at all"), FormatError);
  std::string eight_bit = encode_wav(Pcm{16000, 1, {1, 2}});
  eight_bit[34] = 8;
  EXPECT_THROW(decode_wav(eight_bit), FormatError);
  std::string float_format = encode_wav(Pcm{16000, 1, {1, 2}});
  float_format[20] = 3;
  EXPECT_THROW(decode_wav(float_format), FormatError);
  std::string three_channels = encode_wav(Pcm{16000, 1, {1, 2, 3}});
  three_channels[22] = 3;
  EXPECT_THROW(decode_wav(three_channels), FormatError);
  const std::string header_only = encode_wav(Pcm{16000, 1, {}}).substr(0, 36);
  EXPECT_THROW(decode_wav(header_only), FormatError);
  EXPECT_THROW(samples_from_bytes("abc"), FormatError);
}

TEST(Resample, KeepsAToneInsideTheBand) {
  const auto in = tone(1000, 22050, 1.0, 10000);
  const auto out = resample(in, 22050, 16000);
  EXPECT_EQ(out.size(), 16000u);
  EXPECT_NEAR(rms_middle(out), rms_middle(in), 0.01 * rms_middle(in));
  EXPECT_NEAR(static_cast<double>(rising_zero_crossings(out)), 1000.0, 2.0);
}

TEST(Resample, RemovesAToneAboveTheNewNyquistFrequency) {
  // 10 kHz fits at 22050 Hz but would alias to 6 kHz at 16000 Hz.
  const auto in = tone(10000, 22050, 1.0, 10000);
  const auto out = resample(in, 22050, 16000);
  EXPECT_LT(rms_middle(out), rms_middle(in) / 100.0);  // at least 40 dB down
}

TEST(Resample, UpsamplesAndLeavesEqualRatesAlone) {
  const auto in = tone(440, 8000, 0.5, 8000);
  const auto out = resample(in, 8000, 16000);
  EXPECT_EQ(out.size(), 8000u);
  EXPECT_NEAR(rms_middle(out), rms_middle(in), 0.01 * rms_middle(in));
  EXPECT_EQ(resample(in, 8000, 8000), in);
  const Pcm stereo{48000, 2, std::vector<int16_t>(96000, 100)};
  const auto mono = to_mono(stereo, 16000);
  EXPECT_EQ(mono.size(), 16000u);
  EXPECT_EQ(mono[8000], 100);
}

}  // namespace
}  // namespace urs::audio
