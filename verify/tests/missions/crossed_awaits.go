// Each drone waits for the other before it moves: neither ever does.
package Crossed

var D1 Quadcopter
var D2 Quadcopter

func PAR_Main() {
	SEQ_One()
	SEQ_Two()
}

func SEQ_One() {
	Await("b")
	D1.Arm()
	Signal("a")
}

func SEQ_Two() {
	Await("a")
	D2.Arm()
	Signal("b")
}
