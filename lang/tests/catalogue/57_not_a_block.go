// Block arguments must name functions.
package NotABlock

const Side = 2

var Drone1 Quadcopter

func INIT() {
	If(Drone1.Z() > 1, Drone1, Side)
	WaitUntil(Drone1.Z() > 1, 3)
	Drone1()
}
