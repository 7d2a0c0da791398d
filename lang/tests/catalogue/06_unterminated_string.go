// A string is not closed on its line.
package Unterminated

var Drone1 Quadcopter

func INIT() {
	Signal("ready)
	Drone1.Arm()
}
