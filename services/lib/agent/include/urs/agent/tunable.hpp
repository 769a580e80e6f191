#pragma once
// The capability of a service agent whose parameters may change while it runs (a robot's cruise
// speed, a sensor's noise). Hosts that offer configuration to tools (an RT-Component's
// configuration sets: rtconf, `urs rtc conf`) find it by dynamic_cast on the agent and pass each
// change through; an agent without it has nothing to tune.

#include <string>
#include <vector>

namespace urs::agent {

class Tunable {
 public:
  struct Parameter {
    std::string name;
    std::string value;  // current value, as text (numbers in SI units, as in the agent's params)
  };

  virtual ~Tunable() = default;
  // The tunable parameters with their current values, in a stable order.
  virtual std::vector<Parameter> tunable_parameters() const = 0;
  // "" if `value` is acceptable for `name`, else why not (e.g. "'3' is above max_speed 1.2").
  // Changes nothing. Thread-safe.
  virtual std::string check_parameter(const std::string& name, const std::string& value) const = 0;
  // Makes a value that check_parameter() accepted take effect at once. Thread-safe (called from
  // the host's threads while the agent runs); throws std::invalid_argument for a refused value.
  virtual void set_parameter(const std::string& name, const std::string& value) = 0;
};

}  // namespace urs::agent
