// Three counted loops, two of which only the drone inside can count: D1's
// photos and D2's square touch nothing else, so their rounds are explored
// uncounted. D3 waits in every round for an event D2 signals after its
// square: that loop reads a place outside it, and its rounds are counted.
package Folded

var D1 Quadcopter
var D2 Quadcopter
var D3 Quadcopter

func SEQ_Main() {
	PAR_Up()
	PAR_Work()
	PAR_Down()
}

func PAR_Up() {
	SEQ_Up1()
	SEQ_Up2()
	SEQ_Up3()
}

func SEQ_Up1() {
	D1.Arm()
	D1.Takeoff(1)
}

func SEQ_Up2() {
	D2.Arm()
	D2.Takeoff(1)
}

func SEQ_Up3() {
	D3.Arm()
	D3.Takeoff(1)
}

func PAR_Work() {
	RepeatFor(3, SEQ_Photos)
	SEQ_Squares()
	RepeatFor(2, SEQ_Called)
}

func SEQ_Photos() {
	D1.TakePhoto()
	D1.Hover(1)
}

func SEQ_Squares() {
	RepeatFor(2, SEQ_Square)
	Signal("square")
}

func SEQ_Square() {
	D2.FlyByX(1)
	D2.FlyByY(1)
	D2.FlyByX(-1)
	D2.FlyByY(-1)
}

func SEQ_Called() {
	Await("square")
	D3.TakePhoto()
}

func PAR_Down() {
	D1.Land()
	D2.Land()
	D3.Land()
}
