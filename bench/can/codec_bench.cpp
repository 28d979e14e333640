// SPDX-License-Identifier: Apache-2.0
// Cost of the PA10 codec per frame: what the master and pa10-sim spend per CAN frame.
#include <benchmark/benchmark.h>

#include "arm/can/protocol.h"

namespace {

using namespace rtm::can;

void BM_EncodeDriveCommand(benchmark::State& state) {
  double v = 0.1;
  for (auto _ : state) {
    auto f = encode_drive_command({3, controlword::kEnableOperation, v});
    benchmark::DoNotOptimize(f);
    v += 1e-7;
  }
}
BENCHMARK(BM_EncodeDriveCommand);

void BM_DecodeDriveFeedback(benchmark::State& state) {
  const can_frame f = *encode_drive_feedback({5, statusword::kOperationEnabled, 1.2345, -0.5});
  for (auto _ : state) {
    benchmark::DoNotOptimize(f);
    auto d = decode_drive_feedback(f);
    benchmark::DoNotOptimize(d);
  }
}
BENCHMARK(BM_DecodeDriveFeedback);

void BM_EncodeSensorForceAndTorque(benchmark::State& state) {
  double x = 1.0;
  for (auto _ : state) {
    auto f = encode_sensor_force({kWristSensorNode, {x, -x, 2 * x}});
    auto t = encode_sensor_torque({kWristSensorNode, {0.1 * x, 0.2, -0.3}});
    benchmark::DoNotOptimize(f);
    benchmark::DoNotOptimize(t);
    x += 1e-6;
  }
}
BENCHMARK(BM_EncodeSensorForceAndTorque);

// What a receive loop does per frame: classify by id, then decode.
void BM_ClassifyAndDecodeCycleMix(benchmark::State& state) {
  can_frame frames[11];
  for (int j = 0; j < 7; ++j) {
    frames[j] = *encode_drive_feedback({drive_node(j), statusword::kOperationEnabled, 0.1 * j, 0.01 * j});
  }
  frames[7] = *encode_sensor_force({kWristSensorNode, {1, 2, 3}});
  frames[8] = *encode_sensor_torque({kWristSensorNode, {0.1, 0.2, 0.3}});
  frames[9] = *encode_sensor_force({kJoystickSensorNode, {1, 2, 3}});
  frames[10] = *encode_sensor_torque({kJoystickSensorNode, {0.1, 0.2, 0.3}});
  double sum = 0;
  for (auto _ : state) {
    for (const can_frame& f : frames) {
      benchmark::DoNotOptimize(f);
      const Classified c = classify(f);
      switch (c.type) {
        case FrameType::drive_feedback: sum += decode_drive_feedback(f)->position_rad; break;
        case FrameType::sensor_force: sum += decode_sensor_force(f)->force_N[0]; break;
        case FrameType::sensor_torque: sum += decode_sensor_torque(f)->torque_Nm[0]; break;
        default: break;
      }
    }
  }
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(state.iterations() * 11);
}
BENCHMARK(BM_ClassifyAndDecodeCycleMix);

}  // namespace

BENCHMARK_MAIN();
