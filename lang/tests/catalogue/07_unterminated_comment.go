// A block comment runs to the end of the file.
package OpenComment

var Drone1 Quadcopter

func INIT() {
	Drone1.Arm() /* arm first
	Drone1.Land()
}
