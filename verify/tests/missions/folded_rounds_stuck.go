// D3's rounds are its own, and D1 and D2 each wait for the other: the
// deadlock is shown as a run of the mission as it is, rounds counted.
package FoldedStuck

var D1 Quadcopter
var D2 Quadcopter
var D3 Quadcopter

func PAR_Main() {
	SEQ_One()
	SEQ_Two()
	RepeatFor(2, SEQ_Photos)
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

func SEQ_Photos() {
	D3.TakePhoto()
	D3.TakePhoto()
}
