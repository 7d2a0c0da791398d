// A drone's distance to itself is always 0: comparing it is a mistake,
// whether the drone is named twice or reaches itself through parameters.
package SelfDistance

var D1 Quadcopter
var D2 Quadcopter

func INIT() {
	WaitUntil(D1.DistanceTo(D1) > 2, SEQ_Go)
	SEQ_Keep(D2, D2)
}

func SEQ_Go() {
	D2.Land()
}

func SEQ_Keep(a Quadcopter, b Quadcopter) {
	WaitWhile(a.DistanceTo(a) < 1, SEQ_Go)
	WaitWhile(a.DistanceTo(b) < 1, SEQ_Go)
}
