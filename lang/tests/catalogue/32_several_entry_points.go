// Without INIT, the entry point is the one function nobody calls: here
// there are two.
package TwoRoots

var Drone1 Quadcopter
var Drone2 Quadcopter

func SEQ_First() {
	SEQ_Common()
	Drone1.Land()
}

func SEQ_Second() {
	SEQ_Common()
	Drone2.Land()
}

func SEQ_Common() {
	Drone1.Arm()
}
