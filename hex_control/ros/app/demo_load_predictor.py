"""The interim main job: the Kalman load predictor over real ROS 2 topics.

A synthetic Gauss-Markov normal-force disturbance (``WrenchStamped``, force.z in N) is
published in this process; the ``load_predictor`` node runs as a separate process with
the shipped configuration (which starts from a deliberately rough model and identifies
a, W, V and the mean online); this process records its predictions, prints the skill
against persistence and writes a PNG and a JSON summary.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from tqdm import tqdm

from hex_control.config import config_file
from hex_control.estimation import GaussMarkovModel, expected_skill, skill_score
from hex_control.estimation.kalman import steady_state_variance
from hex_control.estimation.plots import plot_prediction
from hex_control.ros.nodes.synthetic_load import SyntheticLoadNode
from hex_control_msgs.msg import LoadPrediction

#: the load the demo publishes: normal force 40 N mean with a slow disturbance
TRUE_MODEL = GaussMarkovModel(a=0.95, process_variance=0.8, measurement_variance=1.5)
MEAN_FORCE_N = 40.0
INPUT_TOPIC = "/plant/wrench"
PREDICTION_TOPIC = "/load_predictor/force/prediction"
SOURCE_NODE = "/synthetic_load"  # the publisher of INPUT_TOPIC, SyntheticLoadNode
#: samples published but not yet answered, at most: well below every history depth on the way
#: (the predictor's qos_depth 100, the recorder's 100), so a stalled process delays the demo
#: but no KEEP_LAST queue overflows and every sample is predicted
MAX_UNANSWERED = 20
FIRST_RESEND_S = 1.0  # wall s: the first sample, unanswered, is sent again (the start handshake)


def predictor_command() -> list[str]:
    # the shipped force predictor, taking the load from this process's source instead of a plant
    return [sys.executable, "-m", "hex_control.ros.nodes.load_predictor", "--ros-args",
            "-r", "__ns:=/load_predictor", "-r", "__node:=force",
            "--params-file", str(config_file("load_predictor.yaml")), "-p", f"input_owner:={SOURCE_NODE}"]


def run_demo(output: str, samples: int, rate_hz: float, seed: int) -> int:
    out = Path(output)
    out.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ)
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    os.environ.update(env)
    print(f"starting load_predictor: {' '.join(predictor_command()[1:])}")
    process = subprocess.Popen(predictor_command(), env=env)
    rclpy.init()
    executor = SingleThreadedExecutor()
    received: list[LoadPrediction] = []
    try:
        recorder = rclpy.create_node("demo_recorder")
        recorder.create_subscription(LoadPrediction, PREDICTION_TOPIC, received.append, 100)
        executor.add_node(recorder)
        deadline = time.monotonic() + 30.0
        while recorder.count_publishers(PREDICTION_TOPIC) == 0:
            if process.poll() is not None or time.monotonic() > deadline:
                print("load_predictor did not come up", file=sys.stderr)
                return 1
            executor.spin_once(timeout_sec=0.1)
        parameters = {"topic": INPUT_TOPIC, "type": "geometry_msgs/msg/WrenchStamped", "a": TRUE_MODEL.a,
                      "process_variance": TRUE_MODEL.process_variance,
                      "measurement_variance": TRUE_MODEL.measurement_variance, "mean": MEAN_FORCE_N,
                      "rate_hz": rate_hz, "seed": seed, "count": samples, "qos_depth": 100}
        # the series waits for the first sample's answer: a predictor whose reader matched the
        # source's writer only after it was sent has dropped it (volatile DDS), so it is sent
        # again, stamp and all, every FIRST_RESEND_S (the predictor counts a repeat, not a sample)
        source = SyntheticLoadNode(
            may_publish=lambda sent: sent - len(received) < (MAX_UNANSWERED if received else 1),
            parameter_overrides=[Parameter(name, value=value) for name, value in parameters.items()])
        executor.add_node(source)
        # progress, not wall time, ends the wait: a predictor that stays silent for 30 s has failed
        silent_since = resent_at = time.monotonic()
        with tqdm(total=samples, desc="predictions", unit="sample") as bar:
            while len(received) < samples and time.monotonic() - silent_since < 30.0:
                executor.spin_once(timeout_sec=0.1)
                if not received and time.monotonic() - resent_at > FIRST_RESEND_S:
                    source.republish_last()
                    resent_at = time.monotonic()
                if len(received) > bar.n:
                    silent_since = time.monotonic()
                    bar.update(len(received) - bar.n)
    finally:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()
        executor.shutdown()
        rclpy.try_shutdown()
    return report(received, samples, rate_hz, out)


def report(received, samples: int, rate_hz: float, out: Path) -> int:
    if len(received) < samples // 2:
        print(f"only {len(received)} of {samples} predictions arrived", file=sys.stderr)
        return 1
    measurement = np.array([m.measurement for m in received])
    prediction = np.array([m.prediction for m in received])
    # KEEP_LAST transport may drop a sample under load: pair only consecutive ones
    consecutive = np.diff([m.sample_count for m in received]) == 1
    std = np.sqrt([m.prediction_variance + m.model_v for m in received])
    half = len(received) // 2  # the shipped config has identified its model by then
    last = received[-1]
    identified = GaussMarkovModel(last.model_a, last.model_w, last.model_v)
    expected = expected_skill(TRUE_MODEL.a, TRUE_MODEL.process_variance,
                              TRUE_MODEL.measurement_variance, steady_state_variance(TRUE_MODEL))
    summary = {
        "samples_received": len(received),
        "samples_published": samples,
        "true_model": {"a": TRUE_MODEL.a, "W": TRUE_MODEL.process_variance,
                       "V": TRUE_MODEL.measurement_variance, "mean_n": MEAN_FORCE_N},
        "identified_model": {"a": identified.a, "W": identified.process_variance,
                             "V": identified.measurement_variance, "mean_n": last.mean},
        "samples_lost_in_transport": int(np.count_nonzero(~consecutive)),
        "skill_second_half": skill_score(measurement[half:], prediction[half:], consecutive[half:]),
        "skill_all": skill_score(measurement, prediction, consecutive),
        "skill_expected_with_true_model": expected,
        "rmse_prediction_second_half_n": float(np.sqrt(np.mean(
            ((measurement[half + 1:] - prediction[half:-1]) ** 2)[consecutive[half:]]))),
        "rmse_persistence_second_half_n": float(np.sqrt(np.mean(
            (np.diff(measurement[half:]) ** 2)[consecutive[half:]]))),
    }
    time_s = np.arange(len(received)) / rate_hz
    plot_prediction(out / "load_prediction.png", time_s, measurement, prediction, std,
                    quantity="normal force (N)")
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    counts = [m.sample_count for m in received]
    print(f"\nreceived {len(received)}/{samples} predictions over ROS 2; "
          f"gaps in sample_count at {[c for c, d in zip(counts[1:], np.diff(counts)) if d != 1]}")
    print(f"true model       a={TRUE_MODEL.a:.3f} W={TRUE_MODEL.process_variance:.3f} N^2 "
          f"V={TRUE_MODEL.measurement_variance:.3f} N^2 mean={MEAN_FORCE_N:.2f} N")
    print(f"identified model a={identified.a:.3f} W={identified.process_variance:.3f} N^2 "
          f"V={identified.measurement_variance:.3f} N^2 mean={last.mean:.2f} N")
    print(f"skill vs persistence: {summary['skill_second_half']:.3f} (second half, identified model), "
          f"{summary['skill_all']:.3f} (all, incl. the rough start-up model); "
          f"expected with the true model {expected:.3f}")
    print(f"RMSE (second half) of prediction {summary['rmse_prediction_second_half_n']:.3f} N, "
          f"of persistence {summary['rmse_persistence_second_half_n']:.3f} N")
    print(f"wrote {out / 'load_prediction.png'} and {out / 'summary.json'}")
    return 0
