// One copter flies a 4 m square at 2 m and lands where it took off: the
// smallest mission worth flying on a real autopilot first (see the README's
// section on MAVLink drones and `examples/square_fleet.toml`).
package Square

var Copter Quadcopter

func SEQ_Square() {
	Copter.Arm()
	Copter.Takeoff(2)
	Copter.FlyByX(4)
	Copter.FlyByY(4)
	Copter.FlyByX(-4)
	Copter.FlyByY(-4)
	Copter.Land()
	Copter.Disarm()
}
