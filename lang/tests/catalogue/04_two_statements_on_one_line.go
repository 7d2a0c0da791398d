// Two statements on one line need a `;` (or a newline) between them.
package OneLine

var Drone1 Quadcopter

func INIT() {
	Drone1.Arm() Drone1.Takeoff(1)
}
