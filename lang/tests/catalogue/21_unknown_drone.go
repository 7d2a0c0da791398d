// A drone that is not declared, with a close name that is.
package UnknownDrone

var Drone1 Quadcopter

func INIT() {
	Drone1.Arm()
	Drone2.Arm()
}
