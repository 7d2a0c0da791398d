// An action named but not called, and a block named but not called.
package NoParens

var Drone1 Quadcopter

func INIT() {
	Drone1.Arm
	SEQ_Fly
}

func SEQ_Fly() {
	Drone1.Takeoff(1)
}
