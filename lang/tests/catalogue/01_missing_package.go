// The file does not start with `package Name`.
var Drone1 Quadcopter

func INIT() {
	Drone1.Arm()
}
