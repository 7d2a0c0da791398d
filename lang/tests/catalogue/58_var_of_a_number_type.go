// `var` declares drones; numbers are constants.
package VarNumber

var Side float64
var Drone1 Quadcopter

func INIT() {
	Drone1.FlyByX(1)
}
