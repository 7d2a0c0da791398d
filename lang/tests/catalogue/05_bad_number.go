// Malformed number literals: each is reported whole.
package BadNumbers

var Drone1 Quadcopter

func INIT() {
	Drone1.FlyByX(1.2.3)
	Drone1.FlyByY(0x)
	Drone1.Takeoff(1.5m)
}
