// Several syntax errors and one unknown action: all reported in one run.
package ManyErrors

var Drone1 Quadcopter

func INIT() {
	Drone1.Arm()
	Drone1.Takeoff(1.5
	Drone1.FlyByX(1))
	Drone1.Hover(2, )
	Drone1.Teleport(3)
	Drone1.Land()
}

func SEQ_Other() {
	Drone1.FlyByY(,)
}
