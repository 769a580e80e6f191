#pragma once
// `urs record` and `urs play` (docs/dashboard.md, "Recording and playback"): thin commands that
// run the Python SDK's recorder and player (python3 -m urslink.recording), which speak the
// gateway's Foxglove WebSocket as a client and write and read MCAP with the `mcap` package. Every
// argument after the command goes to it unchanged.
//
// The interpreter is $URS_PYTHON, else python3; the SDK is found through $URS_PYTHON_SDK, else
// <prefix>/share/urslink/python next to this program, else the interpreter's own packages (a
// venv with `pip install ./python mcap`). For `play`, $URS_GATEWAY_BIN is set to the urs-gateway
// next to this program when there is one and it is not set already.

namespace urs::cli {

// True for argv of `urs record ...` / `urs play ...`.
bool is_recording_command(int argc, char** argv);
// Replaces this process with the Python tool (execvp); returns only if that failed: 127, with
// the reason on stderr.
int run_recording_command(int argc, char** argv);

}  // namespace urs::cli
