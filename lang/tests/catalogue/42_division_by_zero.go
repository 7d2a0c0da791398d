// Division by a constant zero, in a constant and in a condition.
package DivZero

const Legs = 2 - 2
const Side = 4 / Legs

var D1 Quadcopter

func INIT() {
	WaitUntil(D1.X()/(1-1) > 2, SEQ_Go)
}

func SEQ_Go() {
	D1.Takeoff(1)
}
