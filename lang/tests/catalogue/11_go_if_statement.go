// Go's `if` is not a mission statement: the control structure `If` is.
package GoIf

var Drone1 Quadcopter

func INIT() {
	if Drone1.Battery() > 20 {
		Drone1.Takeoff(1)
	}
}
