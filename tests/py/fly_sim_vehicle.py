#!/usr/bin/env python3
"""Fly `eamos sim-vehicle` from pymavlink, the way a ground station script
flies an ArduPilot copter, and print what it saw as one JSON object.

An independent MAVLink implementation checks the test vehicle: if this
script can fly it, the vehicle speaks MAVLink 2 as ArduPilot does, not
merely as the Rust adapter expects.

Steps: listen (udpin) for the vehicle's heartbeat; note which messages
come before any stream is requested; try to arm before the vehicle is
ready (expect a refusal with a PreArm text); request the streams; wait
for readiness (3D fix, EKF position flags, pre-arm bit, local position);
set GUIDED; try to take off disarmed (expect a refusal); arm; take off;
fly to a local NED target; land; check that LAND disarmed the motors.

Usage: fly_sim_vehicle.py --connect udpin:127.0.0.1:PORT [--timeout S]
Exit status 0 with the JSON report on stdout, 1 with {"error": ...}.
"""

import argparse
import json
import os
import sys
import time

os.environ.setdefault("MAVLINK20", "1")

from pymavlink import mavutil  # noqa: E402

mavlink = mavutil.mavlink

# The streams a ground station needs, and their rates (Hz).
STREAMS = {
    "SYS_STATUS": 2,
    "GPS_RAW_INT": 2,
    "LOCAL_POSITION_NED": 10,
    "GLOBAL_POSITION_INT": 4,
    "EKF_STATUS_REPORT": 2,
    "EXTENDED_SYS_STATE": 2,
}

EKF_POSITION = (
    mavlink.EKF_ATTITUDE
    | mavlink.EKF_VELOCITY_HORIZ
    | mavlink.EKF_POS_HORIZ_REL
    | mavlink.EKF_POS_HORIZ_ABS
    | mavlink.EKF_POS_VERT_ABS
)
PREARM = mavlink.MAV_SYS_STATUS_PREARM_CHECK
POSITION_ONLY = 3576


class Failed(Exception):
    pass


class Station:
    def __init__(self, connect, deadline):
        self.m = mavutil.mavlink_connection(
            connect, source_system=255, source_component=190, dialect="ardupilotmega"
        )
        self.deadline = deadline
        self.last = {}
        self.texts = []

    def remaining(self):
        left = self.deadline - time.monotonic()
        if left <= 0:
            raise Failed("the overall time limit passed")
        return left

    def pump(self, seconds):
        """Reads messages for `seconds`, keeping the latest of each type."""
        end = time.monotonic() + seconds
        seen = []
        while time.monotonic() < end:
            self.remaining()
            msg = self.m.recv_match(blocking=True, timeout=0.05)
            if msg is not None:
                seen.append(self.note(msg))
        return seen

    def note(self, msg):
        kind = msg.get_type()
        if kind == "BAD_DATA":
            return kind
        if msg.get_srcSystem() != self.m.target_system and self.m.target_system:
            return kind
        self.last[kind] = msg
        if kind == "STATUSTEXT":
            self.texts.append(msg.text)
        return kind

    def until(self, what, check, limit=60.0):
        end = time.monotonic() + min(limit, self.remaining())
        while time.monotonic() < end:
            msg = self.m.recv_match(blocking=True, timeout=0.1)
            if msg is not None:
                self.note(msg)
            if check():
                return
        raise Failed("timed out waiting for " + what)

    def command(self, command, params, attempts=3):
        """Sends a COMMAND_LONG; returns (result, statustext seen meanwhile)."""
        texts_before = len(self.texts)
        for attempt in range(attempts):
            self.m.mav.command_long_send(
                self.m.target_system, self.m.target_component, command, attempt, *params
            )
            end = time.monotonic() + 1.5
            while time.monotonic() < end:
                self.remaining()
                msg = self.m.recv_match(blocking=True, timeout=0.1)
                if msg is None:
                    continue
                self.note(msg)
                if msg.get_type() == "COMMAND_ACK" and msg.command == command:
                    # ArduPilot says why before it refuses; give a late
                    # text a moment.
                    if msg.result != mavlink.MAV_RESULT_ACCEPTED and len(self.texts) == texts_before:
                        self.pump(0.3)
                    new = self.texts[texts_before:]
                    return msg.result, (new[-1] if new else None)
        raise Failed("no COMMAND_ACK for command %d" % command)

    def local(self):
        p = self.last.get("LOCAL_POSITION_NED")
        return None if p is None else {"x": p.x, "y": p.y, "z": p.z}

    def armed(self):
        hb = self.last.get("HEARTBEAT")
        return bool(hb and hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)

    def mode(self):
        hb = self.last.get("HEARTBEAT")
        return None if hb is None else hb.custom_mode

    def ready(self):
        gps = self.last.get("GPS_RAW_INT")
        ekf = self.last.get("EKF_STATUS_REPORT")
        sys_status = self.last.get("SYS_STATUS")
        return (
            gps is not None
            and gps.fix_type >= mavlink.GPS_FIX_TYPE_3D_FIX
            and ekf is not None
            and ekf.flags & EKF_POSITION == EKF_POSITION
            and not ekf.flags & mavlink.EKF_CONST_POS_MODE
            and sys_status is not None
            and sys_status.onboard_control_sensors_health & PREARM
            and "LOCAL_POSITION_NED" in self.last
        )


def distance(p, x, y, z):
    return ((p["x"] - x) ** 2 + (p["y"] - y) ** 2 + (p["z"] - z) ** 2) ** 0.5


def fly(args):
    s = Station(args.connect, time.monotonic() + args.timeout)
    report = {}

    hb = s.m.wait_heartbeat(timeout=min(30, s.remaining()))
    if hb is None:
        raise Failed("no heartbeat")
    s.note(hb)
    report["system"] = s.m.target_system
    report["autopilot"] = hb.autopilot
    report["vehicle_type"] = hb.type

    # Before anything is asked, an ArduPilot copter sends little more than
    # HEARTBEAT (and STATUSTEXT).
    report["unrequested"] = sorted(set(s.pump(1.0)) - {"BAD_DATA"})

    # Arming before the vehicle is ready is refused, with the reason.
    result, text = s.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, [1, 0, 0, 0, 0, 0, 0])
    report["arm_before_ready"] = {"result": result, "text": text}

    for name, hz in STREAMS.items():
        msg_id = getattr(mavlink, "MAVLINK_MSG_ID_" + name)
        result, _ = s.command(
            mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, [msg_id, 1e6 / hz, 0, 0, 0, 0, 0]
        )
        if result != mavlink.MAV_RESULT_ACCEPTED:
            raise Failed("%s refused with %d" % (name, result))

    started = time.monotonic()
    s.until("readiness", s.ready, limit=90)
    report["ready_after_wall_seconds"] = round(time.monotonic() - started, 2)
    report["ground"] = s.local()

    s.m.set_mode("GUIDED")
    s.until("GUIDED in the heartbeat", lambda: s.mode() == 4)
    report["mode"] = s.mode()

    result, text = s.command(mavlink.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, 3])
    report["takeoff_disarmed"] = {"result": result, "text": text}

    result, _ = s.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, [1, 0, 0, 0, 0, 0, 0])
    report["arm"] = result
    s.until("armed in the heartbeat", s.armed, limit=10)

    result, _ = s.command(mavlink.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, 3])
    report["takeoff"] = result
    s.until("3 m up", lambda: s.local() is not None and s.local()["z"] <= -2.8)
    s.pump(0.5)
    report["after_takeoff"] = s.local()

    target = (5.0, 2.0, -3.0)
    last_sent = 0.0

    def arrived():
        nonlocal last_sent
        if time.monotonic() - last_sent > 1.0:
            last_sent = time.monotonic()
            s.m.mav.set_position_target_local_ned_send(
                0, s.m.target_system, s.m.target_component,
                mavlink.MAV_FRAME_LOCAL_NED, POSITION_ONLY,
                target[0], target[1], target[2], 0, 0, 0, 0, 0, 0, 0, 0,
            )
        p = s.local()
        return p is not None and distance(p, *target) <= 0.2

    s.until("arrival at the target", arrived)
    s.pump(0.5)
    report["after_move"] = s.local()
    g = s.last["GLOBAL_POSITION_INT"]
    report["global_after_move"] = {
        "lat": g.lat / 1e7,
        "lon": g.lon / 1e7,
        "relative_alt": g.relative_alt / 1e3,
    }

    s.m.set_mode("LAND")
    s.until(
        "touchdown and disarm",
        lambda: not s.armed()
        and "EXTENDED_SYS_STATE" in s.last
        and s.last["EXTENDED_SYS_STATE"].landed_state == mavlink.MAV_LANDED_STATE_ON_GROUND,
    )
    s.pump(0.5)
    report["after_land"] = s.local()
    report["armed_after_land"] = s.armed()
    report["texts"] = s.texts
    return report


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--connect", required=True)
    parser.add_argument("--timeout", type=float, default=150.0)
    args = parser.parse_args()
    try:
        report = fly(args)
    except Failed as e:
        print(json.dumps({"error": str(e)}))
        return 1
    print(json.dumps(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
