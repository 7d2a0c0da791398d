// Characters that are not part of the language.
package Stray

var Drone1 Quadcopter

func INIT() {
	Drone1.Arm() @
	Drone1.Takeoff(1) # climb
}
